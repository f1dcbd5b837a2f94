"""Gathering a report's numbers: every figure and table comes from the library calls the
``--json`` outputs of ``thermrs fit``, ``predict``, ``drift`` and ``diagnose`` make, with the
same defaults, so that a number in the report is the number those commands print.

- ``fit``: :func:`thermrs.fit.fit_alpha` over the training runs (and the paper's start/end
  estimator per training run, :func:`thermrs.fit.fit_alpha_start_end`);
- ``predict --train``: :func:`thermrs.predict.prediction_table` of the held-out runs with the
  time-series α (``series``) and, with one training run, the start/end α per camera and their
  mean;
- ``drift``: :func:`thermrs.heating.heating_curves` and :func:`thermrs.iso9283.iso9283`
  (window 10, tolerance 1 µm) over every run;
- ``diagnose``: :func:`thermrs.diagnose.diagnose` (train, held-out), imported only here and
  only when there are held-out runs.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import polars as pl

from thermrs.defaults import ISO_TOLERANCE_UM, ISO_WINDOW
from thermrs.errors import InputError, ThermrsError
from thermrs.ingest import Extraction, ExtractReport
from thermrs.rig import Rig

__all__ = [
    "ISO_TOLERANCE_UM",
    "ISO_WINDOW",
    "ReportData",
    "RunInput",
    "gather",
    "load_run",
    "run_from_extraction",
]

Step = Callable[[str], None]


@dataclass(frozen=True)
class RunInput:
    """One run as the report sees it.

    Attributes
    ----------
    name
        The run's name (the run table's ``run`` column).
    table
        Its run table (:func:`thermrs.fit.run_table`).
    source
        Where it came from (a path, or a description).
    temperatures
        The thermal and ambient readings (long table of :attr:`thermrs.Extraction.temperatures`),
        or None where not available.
    joints
        Joint states read, or None where not known.
    frames_by_status
        CCD frames by status, or None where the frames table is not available.
    extract_report
        The extraction's report (skipped messages, losses), or None for extracted tables (the
        report is not stored beside them).
    data_loss
        Whether part of the recording was lost.
    recording
        The recording it was extracted from (several runs may share one), or None.
    """

    name: str
    table: pl.DataFrame
    source: str
    temperatures: pl.DataFrame | None = None
    joints: int | None = None
    frames_by_status: dict[str, int] | None = None
    extract_report: ExtractReport | None = None
    data_loss: bool = False
    recording: str | None = None

    @property
    def roi_names(self) -> list[str]:
        """Temperature series of the run table (ROIs and ``ambient``)."""
        return sorted(c[: -len("_c")] for c in self.table.columns if c.endswith("_c"))


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

    visits, temps, frames, joints = ex.visits, ex.temperatures, ex.frames, ex.joints
    if window_ns is not None:
        lo, hi = window_ns

        def cut(df: pl.DataFrame) -> pl.DataFrame:
            return df.filter((pl.col("t_ns") >= lo) & (pl.col("t_ns") <= hi))

        visits, temps, frames, joints = cut(visits), cut(temps), cut(frames), cut(joints)
        # Drift is anchored at the run's first visit (SPEC §4): re-anchor the cut.
        visits = _reanchor(visits)
    table = run_table_from(visits, temps, rig, run=name)
    counts = (
        dict(frames.group_by("status").len().sort("status").iter_rows()) if frames.height else {}
    )
    return RunInput(
        name=name,
        table=table,
        source=source,
        temperatures=temps,
        joints=joints.height,
        frames_by_status={str(k): int(v) for k, v in counts.items()},
        extract_report=ex.report,
        data_loss=ex.report.data_loss,
        recording=recording or source,
    )


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
    from thermrs.runs import split_run_spec

    rig = as_rig(rig)
    path, _ = split_run_spec(spec)
    rt = load_run_tables(spec, rig, name=name, cache=cache)
    for t in rt.tables:
        if t.height == 0:
            raise InputError(f"{spec}: no visit with a spot")
    windows: dict[str, tuple[int, int]] = {}
    for r in rt.runs.iter_rows(named=True):
        windows[r["run"]] = (int(r["start_ns"]), int(r["end_ns"]))

    def window(table: pl.DataFrame) -> tuple[int, int] | None:
        label = str(table["run"][0])
        run = label.rpartition("#")[2] if "#" in label else None
        if run is None and rt.runs.height == 1:
            run = str(rt.runs["run"][0])
        return windows.get(run) if run is not None else None

    if not path.name.endswith(".parquet"):
        ex = rt.extraction
        out = []
        for t in rt.tables:
            w = window(t)
            run = run_from_extraction(
                ex, rig, name=str(t["run"][0]), source=str(path), window_ns=w,
                recording=str(path),
            )  # fmt: skip
            # The run table as every other command builds it (temperatures of its own run).
            out.append(RunInput(**{**run.__dict__, "table": t}))
        return out
    stem = path.name[: -len(".parquet")]
    for part in (".visits", ".temperatures", ".joints", ".runs"):
        stem = stem.removesuffix(part)
    temps = pl.read_parquet(path.with_name(f"{stem}.temperatures.parquet"))
    jp = path.with_name(f"{stem}.joints.parquet")
    fp = path.with_name(f"{stem}.parquet")
    joints_t = pl.read_parquet(jp, columns=["t_ns"]) if jp.exists() else None
    frames = pl.read_parquet(fp, columns=["t_ns", "status"]) if fp.exists() else None
    out = []
    for t in rt.tables:
        w = window(t)

        def cut(df: pl.DataFrame, w: tuple[int, int] | None = w) -> pl.DataFrame:
            return df if w is None else df.filter(pl.col("t_ns").is_between(*w))

        fbs = None
        if frames is not None:
            fbs = {
                str(k): int(v)
                for k, v in cut(frames).group_by("status").len().sort("status").iter_rows()
            }
        out.append(
            RunInput(
                name=str(t["run"][0]),
                table=t,
                source=str(path),
                temperatures=cut(temps),
                joints=None if joints_t is None else cut(joints_t).height,
                frames_by_status=fbs,
                data_loss=rt.data_loss,
                recording=str(path),
            )
        )
    return out


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
            "take one with FILE#RUN, or all with thermrs.report.load_runs"
        )
    return runs[0]


@dataclass
class ReportData:
    """Everything a report shows, computed once (see the module docstring)."""

    rig: Rig
    rig_view: dict[str, Any]
    runs: list[RunInput]
    train: list[str]
    holdout: list[str]
    fit: dict[str, Any] | None
    fit_note: str | None
    alphas: dict[str, float]
    prediction: pl.DataFrame | None
    prediction_in_sample: bool
    series: pl.DataFrame | None
    curves: pl.DataFrame
    iso: dict[str, Any]
    iso_windows: pl.DataFrame
    table4: pl.DataFrame
    diagnosis: Any | None
    diagnosis_note: str | None
    title: str
    paper_reference: bool = False
    #: With an identified effect: the held-out runs predicted by the nominal model and by the
    #: diagnosed one (:func:`thermrs.compensate.shrink_table`), else None.
    diagnosed_prediction: pl.DataFrame | None = None
    #: With an ambiguous diagnosis: the experiment that settles it
    #: (:class:`thermrs.design.DesignResult`) and its rivals' forecast drift on it
    #: (:func:`thermrs.design.rival_drift`), or why there is none.
    design: Any | None = None
    design_drift: pl.DataFrame | None = None
    design_note: str | None = None
    notes: list[str] = field(default_factory=list)
    #: With ``gather(baselines=True)`` and a diagnosis: the regressions beside the physical
    #: models (:class:`thermrs.analyses.baselines.BaselineComparison`), else None.
    baselines: Any | None = None

    def run(self, name: str) -> RunInput:
        """The run called ``name``."""
        for r in self.runs:
            if r.name == name:
                return r
        raise KeyError(name)


def table4(runs: Sequence[RunInput]) -> pl.DataFrame:
    """Table 4-style: per run its span, the temperatures at its first and last visit and every
    camera's drift at its last visit (both chip axes, anchored at its first visit)."""
    rows: list[dict[str, Any]] = []
    for r in runs:
        t = r.table.sort("t_ns")
        t_ns = t["t_ns"].to_numpy()
        row: dict[str, Any] = {
            "run": r.name,
            "hours": float(t_ns[-1] - t_ns[0]) / 3.6e12 if len(t_ns) else float("nan"),
            "visits": t.height,
        }
        for name in r.roi_names:
            y = t[f"{name}_c"].to_numpy()
            ok = np.isfinite(y)
            if ok.any():
                row[f"{name}_start_c"] = float(y[ok][0])
                row[f"{name}_end_c"] = float(y[ok][-1])
        for cam in sorted(set(t["camera"].to_list())):
            tc = t.filter(pl.col("camera") == cam)
            for ax in "uv":
                row[f"{cam}_{ax}_um"] = float(tc[f"drift_{ax}_um"][-1])
        rows.append(row)
    # Every row read for the columns and their types: a run without a temperature has no
    # such key, and the first hundred rows must not decide what the others may hold.
    return pl.DataFrame(rows, infer_schema_length=None)


def _diagnose(
    train: list[pl.DataFrame], holdout: list[pl.DataFrame], rig: Rig
) -> tuple[Any | None, str | None]:
    from thermrs.diagnose import diagnose

    try:
        return diagnose(train, holdout, rig), None
    except ThermrsError as e:
        return None, f"The diagnosis could not be made: {e}"


def gather(
    runs: Sequence[RunInput],
    rig: Rig,
    *,
    train: Sequence[str] | None = None,
    diagnosis: Any | None = None,
    title: str | None = None,
    paper_reference: bool = False,
    step: Step | None = None,
    baselines: bool = False,
) -> ReportData:
    """Compute every number of a report, with the functions the commands call (α and the
    prediction by :func:`thermrs.predict.predict_held_out`, as ``thermrs predict``; the
    diagnosis by :func:`thermrs.diagnose.diagnose`; the design by :func:`thermrs.design.design`).

    Parameters
    ----------
    runs
        The runs, in the order they are shown.
    rig
        The rig they were recorded on.
    train
        Names of the runs α is fitted on (default: the first run); the others are held out:
        predicted with that α and, with at least one held-out run, diagnosed.
    diagnosis
        A diagnosis already made (an object with ``to_json()`` and ``residuals``, as
        :func:`thermrs.diagnose.diagnose` returns); by default one is made when there are
        held-out runs.
    title
        The report's title.
    paper_reference
        Show the paper's printed Table 4 beside the runs' (the simulated paper runs).
    step
        Called with a short description before each stage (progress).
    baselines
        Also fit regressions of the drift on the temperatures on the training runs and score
        them beside the diagnosis (:func:`thermrs.analyses.baselines.compare_baselines`).
    """
    from thermrs.heating import heating_curves
    from thermrs.iso9283 import iso9283

    def say(what: str) -> None:
        if step is not None:
            step(what)

    train_names, holdout_names = _roles(runs, train)
    by = {r.name: r for r in runs}
    tr = [by[n].table for n in train_names]
    ho = [by[n].table for n in holdout_names]
    if diagnosis is not None and hasattr(diagnosis, "check_runs"):
        # A diagnosis of other runs cannot be passed on (one line, InputError).
        diagnosis.check_runs(train_names, holdout_names, tables=[*tr, *ho], rig=rig)

    say("checking the rig")
    rig_view = rig.check()

    say("fitting α")
    fitted = _fit_and_predict(tr, ho, rig, paper_reference=paper_reference, say=say)

    say("fitting heating curves")
    every = pl.concat([r.table for r in runs], how="diagonal_relaxed")
    curves = heating_curves(every)
    iso = iso9283(every, window=ISO_WINDOW, tolerance_um=ISO_TOLERANCE_UM)

    diag, note = diagnosis, None
    if diag is None:
        diag, note = _diagnosis(tr, ho, rig, fitted.note, say)
    diagnosed = _diagnosed_prediction(diag, ho, rig) if diag is not None and ho else None
    designed, design_note = _design(tr, ho, rig, diag, say) if diag is not None else (None, None)
    from thermrs.design import rival_drift

    design_drift = rival_drift(designed) if designed is not None else None
    compared = None
    if baselines and diag is not None and ho and hasattr(diag, "residuals"):
        from thermrs.diagnose.baselines import compare_baselines

        say("fitting the regressions beside the physical model")
        compared = compare_baselines(tr, ho, rig, diagnosis=diag)

    return ReportData(
        rig=rig,
        rig_view=rig_view,
        runs=list(runs),
        train=train_names,
        holdout=holdout_names,
        fit=fitted.doc,
        fit_note=fitted.note,
        alphas=fitted.alphas,
        prediction=fitted.prediction,
        prediction_in_sample=not ho,
        series=fitted.series,
        curves=curves,
        iso=iso.to_json(),
        iso_windows=iso.windows,
        table4=table4(runs),
        diagnosis=diag,
        diagnosis_note=note,
        diagnosed_prediction=diagnosed,
        design=designed,
        design_drift=design_drift,
        design_note=design_note,
        title=title or f"Thermal drift of {rig.name or rig.model}",
        paper_reference=paper_reference,
        baselines=compared,
    )


def _roles(runs: Sequence[RunInput], train: Sequence[str] | None) -> tuple[list[str], list[str]]:
    """The names of the training runs (default: the first) and of the held-out ones."""
    if not runs:
        raise InputError("no run to report on")
    names = [r.name for r in runs]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise InputError(f"runs {dup} are given twice (every run needs its own name)")
    train_names = list(train) if train else [names[0]]
    unknown = [n for n in train_names if n not in names]
    if unknown:
        raise InputError(f"training run(s) {unknown} are not among the runs {names}")
    return train_names, [n for n in names if n not in train_names]


@dataclass
class _Fitted:
    """α fitted on the training runs and what it predicts (or why nothing was)."""

    doc: dict[str, Any] | None = None
    alphas: dict[str, float] = field(default_factory=dict)
    prediction: pl.DataFrame | None = None
    series: pl.DataFrame | None = None
    note: str | None = None


def _fit_and_predict(
    tr: list[pl.DataFrame],
    ho: list[pl.DataFrame],
    rig: Rig,
    *,
    paper_reference: bool,
    say: Callable[[str], object],
) -> _Fitted:
    """α on the training runs; the held-out runs (else the training runs) predicted with it,
    as ``thermrs predict`` does (:func:`thermrs.predict.predict_held_out`)."""
    from thermrs.predict import predict_held_out, prediction_table

    out = _Fitted()
    try:
        say("predicting")
        # The paper compares drift along its cameras' y axis (v): so does its demo, and along
        # x (u) beside it (`thermrs predict --axis u`), where the same α errs the other way.
        axis = "v" if paper_reference else "auto"
        p = predict_held_out(tr, ho if ho else tr, rig, axis=axis)
        assert p.fit is not None
        out.doc = p.fit.to_json()
        out.alphas.update(p.alphas)
        out.prediction = p.table
        if axis == "v":
            along_u = prediction_table(ho if ho else tr, rig, alphas=p.alphas, axis="u")
            out.prediction = pl.concat([p.table, along_u])
        out.series = p.series.filter(pl.col("alpha") == "series").drop("alpha")
    except InputError as e:
        out.note = f"α could not be fitted, so nothing was predicted: {e}."
    return out


def _diagnosis(
    tr: list[pl.DataFrame],
    ho: list[pl.DataFrame],
    rig: Rig,
    fit_note: str | None,
    say: Callable[[str], object],
) -> tuple[Any | None, str | None]:
    """A diagnosis made here, or why none was."""
    if fit_note is not None:
        return None, "No diagnosis: " + fit_note
    if not ho:
        return None, (
            "One run only: a diagnosis needs runs held out from the fit, so none was made. "
            "Give more runs to diagnose where the nominal model falls short."
        )
    say("diagnosing")
    return _diagnose(tr, ho, rig)


def _diagnosed_prediction(diag: Any, ho: list[pl.DataFrame], rig: Rig) -> pl.DataFrame | None:
    """The held-out runs predicted by the nominal and the diagnosed model (with an effect)."""
    from thermrs.compensate import diagnosed_model, predict_series, shrink_table

    try:
        model = diagnosed_model(diagnosis_json(diag), rig)
    except InputError:  # a diagnosis without the effect's α: nothing to predict with
        return None
    if model is None or not model.effects:
        return None
    return shrink_table(predict_series(ho, rig, model))


def _design(
    train: list[pl.DataFrame],
    holdout: list[pl.DataFrame],
    rig: Rig,
    diag: Any,
    say: Callable[[str], object],
) -> tuple[Any | None, str | None]:
    """For an ambiguous diagnosis, the experiment that settles it (or why there is none)."""
    doc = diagnosis_json(diag)
    if (doc.get("verdict") or {}).get("status") != "ambiguous":
        return None, None
    from thermrs.design import design

    say("designing the experiment that settles it")
    try:
        res = design(train, holdout, rig, budget_h=24.0, diagnosis=doc)
    except ThermrsError as e:
        return None, f"No experiment could be designed: {e}"
    return (res, None) if res.confounded else (None, None)


def diagnosis_json(diag: Any) -> dict[str, Any]:
    """The diagnosis as its JSON document (an object with ``to_json()``, or a mapping)."""
    if isinstance(diag, Mapping):
        return dict(diag)
    doc = diag.to_json()
    if not isinstance(doc, dict):
        raise TypeError("Diagnosis.to_json() must return a dict")
    return doc


def diagnosis_residuals(diag: Any) -> pl.DataFrame | None:
    """The diagnosis' per-visit residuals, or None."""
    res = getattr(diag, "residuals", None)
    return res if isinstance(res, pl.DataFrame) and res.height else None
