"""Runs inside a recording: find them, name them, select one (``rec.mcap#run2``).

A run (SPEC §1) is one stretch of work from a start temperature; its drift is anchored at the
first visit of each camera in the run. One recording may hold several runs (a session
restarted, a cool-down recorded in the same file, the paper's three runs simulated in one
go). Runs are found in one of two ways:

Run markers
    MCAP Metadata records named ``thermrs.run`` (written by ``thermrs simulate``; a thermrs
    extension of SPEC §2 that other writers leave out) with keys ``name``, ``start_ns`` and
    ``end_ns`` (header stamps, inclusive). When a recording has any, they define its runs.
Idle gaps
    Otherwise a recording splits where no camera is visited for longer than the idle
    threshold: ``max(min_gap_s, gap_factor × cadence)``, the cadence being the median time
    between consecutive visits of one camera (the work cycle). The robot idled there, or the
    recorder was stopped (its joint states stop too). Runs are named ``run1``, ``run2``, … in
    time order. A run found this way spans from its first visit to one cadence after its last
    (the rest of its last cycle, where a thermal frame may close it).

The ``runs`` table has one row per run: ``run`` (name), ``start_ns``, ``end_ns`` and
``source`` (``"marker"`` or ``"gap"``). Visits carry a ``run`` column (null for a visit no
marker covers).

Selecting runs: a path ``rec.mcap#run2`` (or ``rec.visits.parquet#run2``) names one run of a
file; a path without ``#`` names all of them, each giving one run table named ``<stem>#<run>``
(``<stem>`` alone when the file holds one run).

Finding and labelling runs (pure functions of the Metadata records and visits) lives in
:mod:`thermrs.rundetect`, which extraction uses; this module adds the file side (selecting a run,
loading run tables) and re-exports the detection names.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import polars as pl

from thermrs.errors import InputError
from thermrs.identity import RIG_KEY, check_rig
from thermrs.ingest import NOT_A_BAG, data_loss, extract, is_bag, stat_of
from thermrs.rig import as_rig
from thermrs.rundetect import (
    DEFAULT_GAP_FACTOR,
    DEFAULT_MIN_GAP_S,
    RUN_METADATA,
    RUNS_SCHEMA,
    find_runs,
    label_runs,
    runs_from_gaps,
    runs_from_markers,
)
from thermrs.rundetect import cadence_s as cadence_s
from thermrs.runtable import run_table_from
from thermrs.visits import anchor_drift

__all__ = [
    "DEFAULT_GAP_FACTOR",
    "DEFAULT_MIN_GAP_S",
    "PLAUSIBLE_C",
    "RUNS_SCHEMA",
    "RUN_METADATA",
    "RunTables",
    "check_temperatures",
    "find_runs",
    "label_runs",
    "load_runs",
    "runs_from_gaps",
    "runs_from_markers",
    "same_runs",
    "split_run_spec",
]


def split_run_spec(spec: str | Path) -> tuple[Path, str | None]:
    """``"rec.mcap#run2"`` → (``rec.mcap``, ``"run2"``); a path without ``#`` (or one that
    exists as written) → (path, None)."""
    s = str(spec)
    if "#" not in s or Path(s).exists():
        return Path(s), None
    path, _, run = s.rpartition("#")
    if not run:
        raise InputError(f"{s}: no run name after '#'")
    return Path(path), run


#: Temperatures a robot's links or its hall can have (°C); outside them a reading is in other
#: units (kelvin) or broken.
PLAUSIBLE_C = (-40.0, 150.0)


def check_temperatures(table: pl.DataFrame, where: str) -> None:
    """Every temperature of a run table within :data:`PLAUSIBLE_C`, or a clear error.

    Raises
    ------
    InputError
        A reading outside −40…150 °C, naming the series, the run and the value (and kelvin
        where it reads like it).
    """
    for c in table.columns:
        if not c.endswith("_c") or not table[c].dtype.is_numeric():
            continue
        x = table[c].drop_nulls().to_numpy().astype(np.float64)
        x = x[np.isfinite(x)]
        if not len(x):
            continue
        lo, hi = float(x.min()), float(x.max())
        if lo >= PLAUSIBLE_C[0] and hi <= PLAUSIBLE_C[1]:
            continue
        bad = hi if hi > PLAUSIBLE_C[1] else lo
        kelvin = 233.0 <= bad <= 423.0
        raise InputError(
            f"{where}: {c[:-2]} reads {bad:.1f} °C, "
            f"outside {PLAUSIBLE_C[0]:g}…{PLAUSIBLE_C[1]:g} °C"
            + (
                f" (kelvin? {bad:.1f} K is {bad - 273.15:.1f} °C: the recording or the rig's "
                "thermal scale/offset gives kelvin)"
                if kelvin
                else ""
            )
        )


def same_runs(a: Sequence[pl.DataFrame], b: Sequence[pl.DataFrame]) -> list[tuple[str, str]]:
    """Pairs (run of ``a``, run of ``b``) whose visits are identical (same cameras, times and
    spots): one run given twice, e.g. a copy of a training recording as a held-out run."""

    def key(t: pl.DataFrame) -> int:
        return int(t.select("camera", "t_ns", "u_um", "v_um").hash_rows().sum())

    ka = [(str(t["run"][0]), key(t)) for t in a if t.height]
    kb = [(str(t["run"][0]), key(t)) for t in b if t.height]
    return [(na, nb) for na, x in ka for nb, y in kb if x == y]


@dataclass(frozen=True)
class RunTables:
    """The run tables read from one file (:func:`load_runs`).

    Attributes
    ----------
    path
        The file.
    runs
        Every run the file holds (the runs table), whether selected or not.
    tables
        One run table per selected run (:func:`thermrs.fit.run_table_from`), its ``run``
        column ``<stem>#<run>`` (``<stem>`` alone when the file holds one run).
    data_loss
        Whether the recording lost data (for extracted tables: as their metadata records).
    extraction
        The extraction of a recording (:class:`thermrs.Extraction`: frames, joints, the
        report), None for extracted tables.
    """

    path: Path
    runs: pl.DataFrame
    tables: list[pl.DataFrame]
    data_loss: bool
    extraction: Any = None

    def describe(self) -> str:
        """One line: the runs found, their source and length, and which were selected."""
        if self.runs.height == 0:
            return f"{self.path}: one run (no run markers, no idle gap)"
        src = set(self.runs["source"].to_list())
        how = "run markers" if src == {"marker"} else "idle gaps" if src == {"gap"} else "file"
        parts = [
            f"{r['run']} ({(r['end_ns'] - r['start_ns']) / 3.6e12:.1f} h)"
            for r in self.runs.iter_rows(named=True)
        ]
        chosen = ", ".join(str(t["run"][0]) for t in self.tables if t.height)
        n = self.runs.height
        return f"{self.path}: {n} run{'s' * (n != 1)} ({how}): {', '.join(parts)}; using {chosen}"


def _read_tables(
    path: Path,
) -> tuple[pl.DataFrame, pl.DataFrame, pl.DataFrame | None, dict[str, Any] | None]:
    """Visits, temperatures and (if written) runs tables that ``thermrs extract`` wrote, and
    the identity of the rig they were extracted with (None in tables written before it was
    recorded)."""
    stem = path.name[: -len(".parquet")]
    for part in (".visits", ".temperatures", ".joints", ".runs"):
        if stem.endswith(part):
            stem = stem[: -len(part)]
    need = {k: path.with_name(f"{stem}.{k}.parquet") for k in ("visits", "temperatures")}
    for k, p in need.items():
        if not p.exists():
            raise InputError(f"{path}: the {k} table {p.name} is not beside it")
    runs_path = path.with_name(f"{stem}.runs.parquet")
    try:
        visits = pl.read_parquet(need["visits"])
        temps = pl.read_parquet(need["temperatures"])
        runs = pl.read_parquet(runs_path) if runs_path.exists() else None
    except (OSError, pl.exceptions.PolarsError) as e:
        raise InputError(f"{path}: cannot read the extracted tables: {e}") from None
    missing = [c for c in ("camera", "t_ns", "n_ok", "u_um", "v_um") if c not in visits.columns]
    if missing:
        raise InputError(f"{need['visits']}: not a visits table (no {missing})")
    identity = None
    raw = pl.read_parquet_metadata(need["visits"]).get(RIG_KEY)
    if raw:
        try:
            identity = json.loads(raw)
        except ValueError:
            raise InputError(f"{need['visits']}: its rig identity is not JSON") from None
    return visits, temps, runs, identity if isinstance(identity, dict) else None


def load_runs(
    spec: str | Path,
    rig: Any,
    *,
    name: str | None = None,
    temperature: str = "peak",
    cache: dict[Any, Any] | None = None,
) -> RunTables:
    """Run tables of one file: a recording (``.mcap``, extracted here) or the tables
    ``thermrs extract`` wrote (any of its ``.parquet`` files), with an optional ``#run``.

    Parameters
    ----------
    spec
        ``path`` (every run of the file) or ``path#run`` (that run).
    rig
        The rig (:class:`thermrs.Rig`).
    name
        The base name of the run tables (default the file's stem).
    temperature
        ``"peak"`` or ``"max"`` (see :func:`thermrs.fit.run_table_from`).
    cache
        A dict kept between calls: a file read once (a recording extracted once) serves
        every run asked of it (``rec.mcap#run1`` and ``rec.mcap#run2``); keyed by path,
        modification time and size.

    Raises
    ------
    InputError
        No such file, or no such run in it (the message lists the runs it has).
    """
    rig = as_rig(rig)
    path, wanted = split_run_spec(spec)
    if path.is_dir() and not is_bag(path):
        raise InputError(f"{path}: {NOT_A_BAG}")
    if not path.exists():
        raise InputError(f"{path}: no such file")
    if path.is_dir():
        size, mtime = stat_of(path)
    else:
        st = path.stat()
        size, mtime = st.st_size, st.st_mtime_ns
    key = (path.resolve(), mtime, size)
    ex: Any = None
    if cache is not None and key in cache:
        visits, temps, runs, loss, stem, ex = cache[key]
    elif path.name.endswith(".parquet"):
        visits, temps, read_runs, identity = _read_tables(path)
        # Tables extracted with another rig's cameras or ROIs would be analysed as nonsense.
        check_rig(
            str(path),
            rig,
            identity,
            cameras=visits["camera"].unique().to_list(),
            temperatures=temps["name"].unique().to_list() if "name" in temps.columns else [],
            fix="give the rig they were extracted with, or extract the recording again with "
            "this one",
            made="extracted",
        )
        stem = path.name[: -len(".parquet")]
        for part in (".visits", ".temperatures", ".joints", ".runs"):
            stem = stem.removesuffix(part)
        # The loss of the recording they came from travels in the tables' metadata.
        loss = any(
            data_loss(path.with_name(f"{stem}.{k}.parquet")) for k in ("visits", "temperatures")
        )
        runs = read_runs
        if runs is None or "run" not in visits.columns:
            runs = pl.DataFrame(schema=RUNS_SCHEMA)
    else:
        ex = extract(path, rig)
        visits, temps, runs, loss = ex.visits, ex.temperatures, ex.runs, ex.report.data_loss
        stem = path.name[: -len(".mcap")] if path.name.endswith(".mcap") else path.stem
    if cache is not None:
        cache[key] = (visits, temps, runs, loss, stem, ex)
    base = name or stem
    if runs.height == 0 or "run" not in visits.columns:
        if wanted is not None:
            raise InputError(f"{spec}: {path} holds no named runs (use it without '#')")
        table = run_table_from(visits, temps, rig, run=base, temperature=temperature)
        check_temperatures(table, str(spec))
        return RunTables(path, runs, [table], loss, ex)
    names = runs["run"].to_list()
    if wanted is not None and wanted not in names:
        raise InputError(f"{spec}: no run {wanted!r} in {path} (it has {', '.join(names)})")
    selected = [wanted] if wanted is not None else names
    tables = []
    for r in runs.filter(pl.col("run").is_in(selected)).iter_rows(named=True):
        v = anchor_drift(visits.filter(pl.col("run") == r["run"]))
        tt = temps.filter(pl.col("t_ns").is_between(r["start_ns"], r["end_ns"]))
        label = base if runs.height == 1 else f"{base}#{r['run']}"
        tables.append(run_table_from(v, tt, rig, run=label, temperature=temperature))
        check_temperatures(tables[-1], f"{path}#{r['run']}")
    return RunTables(path, runs, tables, loss, ex)
