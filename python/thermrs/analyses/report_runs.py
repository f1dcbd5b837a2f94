"""A report's runs, read: one :class:`~thermrs.report.data.RunInput` per run (its run table,
temperatures, joint states, frames by status and extraction report) from a recording or the
tables ``thermrs extract`` wrote, split into runs as every command splits them
(:mod:`thermrs.runs`), or cut out of one extraction at given times (the demo); and the
``--train``/``--run`` specs of ``thermrs report``, each read once and named as every command
names them. A campaign's runs: :mod:`thermrs.analyses.report`."""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import polars as pl

from thermrs.analyses.inputs import Say
from thermrs.errors import InputError
from thermrs.ingest import Extraction
from thermrs.report.data import RunInput
from thermrs.rig import Rig

__all__ = [
    "ReportRuns",
    "frames_by_status",
    "load_run",
    "load_runs",
    "read_report_runs",
    "run_from_extraction",
    "run_input",
    "run_inputs",
]


def run_from_extraction(
    ex: Extraction,
    rig: Rig,
    *,
    name: str,
    source: str,
    window_ns: tuple[int, int] | None = None,
    recording: str | None = None,
) -> RunInput:
    """A :class:`RunInput` from an extraction, optionally only the visits, readings and frames
    inside ``window_ns`` (a recording that holds several runs, cut at their times)."""
    from thermrs.fit import run_table_from

    visits = ex.visits
    if window_ns is not None:
        lo, hi = window_ns
        # Drift is anchored at the run's first visit (SPEC §4): re-anchor the cut.
        visits = _reanchor(visits.filter(pl.col("t_ns").is_between(lo, hi)))
    temps = _cut(ex.temperatures, window_ns)
    return run_input(
        run_table_from(visits, temps, rig, run=name),
        temperatures=temps,
        joints=ex.joints,
        frames=ex.frames,
        window_ns=window_ns,
        source=source,
        recording=recording or source,
        extract_report=ex.report,
        data_loss=ex.report.data_loss,
    )


def run_input(
    table: pl.DataFrame,
    *,
    temperatures: pl.DataFrame | None,
    joints: pl.DataFrame | None,
    frames: pl.DataFrame | None,
    window_ns: tuple[int, int] | None,
    source: str,
    recording: str,
    extract_report: Any = None,
    data_loss: bool = False,
) -> RunInput:
    """A :class:`RunInput`: the one builder, for a recording, extracted tables and a campaign.

    Parameters
    ----------
    table
        The run's run table (its name is the table's ``run``).
    temperatures, joints, frames
        The whole recording's readings, joint states (a ``t_ns`` column) and frames (``t_ns``
        and ``status``), or None where the file is absent; each cut to ``window_ns``.
    window_ns
        The run's first and last nanosecond (both kept), or None: the tables are the run's.
    source, recording, extract_report, data_loss
        As :class:`RunInput`.

    Returns
    -------
    RunInput
        The run, its joint states counted and its frames counted by status.

    Raises
    ------
    polars.exceptions.ColumnNotFoundError
        A table without ``t_ns`` (or frames without ``status``).

    Examples
    --------
    >>> ex = thermrs.extract("rec.mcap", rig)  # doctest: +SKIP
    >>> from thermrs.fit import run_table_from
    >>> table = run_table_from(ex.visits, ex.temperatures, rig, run="rec")  # doctest: +SKIP
    >>> run_input(table, temperatures=ex.temperatures, joints=ex.joints, frames=ex.frames,
    ...           window_ns=None, source="rec.mcap", recording="rec.mcap")  # doctest: +SKIP
    """
    return RunInput(
        name=str(table["run"][0]),
        table=table,
        source=source,
        temperatures=None if temperatures is None else _cut(temperatures, window_ns),
        joints=None if joints is None else _cut(joints, window_ns).height,
        frames_by_status=None if frames is None else frames_by_status(_cut(frames, window_ns)),
        extract_report=extract_report,
        data_loss=data_loss,
        recording=recording,
    )


def _cut(df: pl.DataFrame, window_ns: tuple[int, int] | None) -> pl.DataFrame:
    """The rows of ``df`` inside the window (both ends kept), all of them without one."""
    return df if window_ns is None else df.filter(pl.col("t_ns").is_between(*window_ns))


def frames_by_status(frames: pl.DataFrame) -> dict[str, int]:
    """A frames table's CCD frames counted by status (``ok``, ``no_spot``, …), as the
    report's extraction section shows them."""
    if not frames.height:
        return {}
    return {str(k): int(v) for k, v in frames.group_by("status").len().sort("status").iter_rows()}


def _reanchor(visits: pl.DataFrame) -> pl.DataFrame:
    """Drift columns anchored at each camera's first visit with ``ok`` frames."""
    if not {"drift_u_um", "drift_v_um"} <= set(visits.columns):
        return visits
    v = visits.sort("camera", "t_ns")
    return v.with_columns(
        drift_u_um=pl.col("u_um") - pl.col("u_um").drop_nulls().first().over("camera"),
        drift_v_um=pl.col("v_um") - pl.col("v_um").drop_nulls().first().over("camera"),
    )


def load_runs(
    spec: str | Path,
    rig: Rig | str | os.PathLike[str],
    *,
    name: str | None = None,
    cache: dict[Any, Any] | None = None,
) -> list[RunInput]:
    """The runs of a recording (``.mcap``, extracted here) or of the tables ``thermrs
    extract`` wrote, one :class:`RunInput` per run, split as every other command splits them
    (:mod:`thermrs.runs`: run markers, else idle gaps); ``FILE#RUN`` takes one run.

    Parameters
    ----------
    spec
        ``path`` (each of its runs) or ``path#run``.
    rig
        The rig it was recorded on (or the path of its file).
    name
        The base name of the runs (default the file's stem): ``<name>#<run>``, or ``<name>``
        alone when the file holds one run.
    cache
        Files read once serve every run asked of them (see :func:`thermrs.runs.load_runs`).

    Raises
    ------
    InputError
        No such file, no such run, or a run without a visit with a spot.
    """
    from thermrs.rig import as_rig
    from thermrs.runs import load_runs as load_run_tables

    rig = as_rig(rig)
    rt = load_run_tables(spec, rig, name=name, cache=cache)
    for t in rt.tables:
        if t.height == 0:
            raise InputError(f"{spec}: no visit with a spot")
    return run_inputs(rt)


def run_inputs(rt: Any) -> list[RunInput]:
    """A file's runs read (:class:`thermrs.runs.RunTables`) as :class:`RunInput` s: each with
    its readings, joint states and frames, cut at its times (:func:`run_input`).

    Parameters
    ----------
    rt
        What :func:`thermrs.runs.load_runs` read (or :func:`thermrs.analyses.read_files`
        gave).

    Returns
    -------
    list of RunInput
        One per run table, in order.

    Raises
    ------
    OSError
        Extracted tables whose temperatures table is missing.

    Examples
    --------
    >>> from thermrs.runs import load_runs
    >>> runs = run_inputs(load_runs("rec.mcap", rig))  # doctest: +SKIP
    """
    path = rt.path
    windows = {
        str(r["run"]): (int(r["start_ns"]), int(r["end_ns"])) for r in rt.runs.iter_rows(named=True)
    }

    def window(table: pl.DataFrame) -> tuple[int, int] | None:
        label = str(table["run"][0])
        run = label.rpartition("#")[2] if "#" in label else None
        if run is None and rt.runs.height == 1:
            run = str(rt.runs["run"][0])
        return windows.get(run) if run is not None else None

    if not path.name.endswith(".parquet"):
        ex = rt.extraction
        temps, joints_t, frames = ex.temperatures, ex.joints, ex.frames
        report, loss = ex.report, ex.report.data_loss
    else:
        stem = path.name[: -len(".parquet")]
        for part in (".visits", ".temperatures", ".joints", ".runs"):
            stem = stem.removesuffix(part)
        temps = pl.read_parquet(path.with_name(f"{stem}.temperatures.parquet"))
        jp = path.with_name(f"{stem}.joints.parquet")
        fp = path.with_name(f"{stem}.parquet")
        joints_t = pl.read_parquet(jp, columns=["t_ns"]) if jp.exists() else None
        frames = pl.read_parquet(fp, columns=["t_ns", "status"]) if fp.exists() else None
        report, loss = None, rt.data_loss
    # The run table as every other command builds it (temperatures of its own run).
    return [
        run_input(
            t,
            temperatures=temps,
            joints=joints_t,
            frames=frames,
            window_ns=window(t),
            source=str(path),
            recording=str(path),
            extract_report=report,
            data_loss=loss,
        )
        for t in rt.tables
    ]


def load_run(
    path: str | Path, rig: Rig | str | os.PathLike[str], *, name: str | None = None
) -> RunInput:
    """One run of a recording or of extracted tables (``FILE`` holding one run, or
    ``FILE#RUN``); see :func:`load_runs`.

    Raises
    ------
    InputError
        No such file, no visit with a spot, or a file of several runs given without ``#RUN``
        (the runs would be merged into one: use :func:`load_runs`).
    """
    runs = load_runs(path, rig, name=name)
    if len(runs) > 1:
        raise InputError(
            f"{path} holds {len(runs)} runs ({', '.join(r.name for r in runs)}): "
            "take one with FILE#RUN, or all with thermrs.analyses.report_runs.load_runs"
        )
    return runs[0]


@dataclass
class ReportRuns:
    """The report's runs (each once, in the order read), the training runs' names and whether
    any recording lost data."""

    runs: list[RunInput] = field(default_factory=list)
    train: list[str] = field(default_factory=list)
    data_loss: bool = False


def read_report_runs(
    train: Sequence[Path],
    runs: Sequence[Path],
    rig: Rig,
    *,
    say: Say | None = None,
    step: Say | None = None,
) -> ReportRuns:
    """Read the ``train`` then the ``runs`` specs (a spec given in both read once) with the
    loader every command uses (:func:`thermrs.analyses.inputs.read_files`).

    Parameters
    ----------
    train, runs
        ``FILE`` or ``FILE#RUN`` specs (see :func:`load_runs`).
    rig
        The rig they were recorded on.
    say
        Told the runs found in each file, and once per file that it lost data.
    step
        Told ``reading SPEC (i/n)`` before each spec is read.

    Returns
    -------
    ReportRuns
        Each run once, in the order read; the training runs' names; whether data was lost.

    Raises
    ------
    InputError
        As :func:`thermrs.analyses.inputs.read_files`.

    Examples
    --------
    >>> got = read_report_runs([Path("r30.mcap")], [Path("r75.mcap")], rig)  # doctest: +SKIP
    >>> got.train  # doctest: +SKIP
    ['r30']
    """
    from thermrs.analyses.inputs import read_files
    from thermrs.runs import split_run_spec

    def key(p: Path) -> str:
        base, run = split_run_spec(p)
        return f"{base.resolve()}#{run}"

    chosen: dict[str, tuple[Path, str]] = {}
    for p in train:
        chosen.setdefault(key(p), (p, "--train"))
    for p in runs:
        chosen.setdefault(key(p), (p, "--run"))
    specs = list(chosen.values())
    out = ReportRuns()
    cache: dict[object, object] = {}
    read = read_files(
        [p for p, _ in specs], rig, [w for _, w in specs], say=say, step=step, cache=cache
    )
    for f in read:
        out.data_loss |= f.runs.data_loss
        for r in run_inputs(f.runs):
            if r.name in {x.name for x in out.runs}:
                continue
            out.runs.append(r)
            if f.what == "--train":
                out.train.append(r.name)
    return out
