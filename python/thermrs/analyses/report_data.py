"""Every number of a report, from the results the commands render: a report's runs become one
:class:`~thermrs.analyses.inputs.Split` (the training runs, the held-out ones), and the page's
α and prediction are :func:`~thermrs.analyses.predict.predict_splits`' (``thermrs predict``),
its heating curves and ISO 9283-style figures :func:`~thermrs.analyses.drift.drift_tables`'
(``thermrs drift``), its diagnosis :func:`~thermrs.analyses.diagnose.diagnose_splits`' with the
same defaults and ``exclude`` (``thermrs diagnose``) or the one given, its diagnosed prediction
:func:`~thermrs.analyses.predict.predict_diagnosed`'s (``thermrs predict --diagnosis``), its
design :func:`~thermrs.analyses.design.design_splits`' (``thermrs design --diagnosis``) and its
regressions :func:`~thermrs.analyses.baselines.baselines_folds`' (``thermrs diagnose
--baselines``). :mod:`thermrs.report` renders the :class:`~thermrs.report.data.ReportData`
this returns and computes nothing."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
import polars as pl

from thermrs.analyses.diagnose import DiagnosisFold, diagnose_splits
from thermrs.analyses.drift import drift_tables
from thermrs.analyses.inputs import Split
from thermrs.analyses.predict import predict_diagnosed, predict_splits
from thermrs.defaults import DESIGN_BUDGET_H, ISO_TOLERANCE_UM, ISO_WINDOW
from thermrs.errors import InputError, ThermrsError
from thermrs.report.data import ReportData, RunInput, Step, diagnosis_json
from thermrs.rig import Rig

if TYPE_CHECKING:  # pragma: no cover
    from thermrs.design import DesignResult
    from thermrs.diagnose.result import Diagnosis

__all__ = ["report_data", "report_split", "table4"]


def report_data(
    runs: Sequence[RunInput],
    rig: Rig,
    *,
    train: Sequence[str] | None = None,
    diagnosis: Diagnosis | None = None,
    exclude: Sequence[str] = (),
    title: str | None = None,
    paper_reference: bool = False,
    step: Step | None = None,
    baselines: bool = False,
) -> ReportData:
    """Every number a report shows, each the one the command that prints it gives (see the
    module docstring).

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
        A diagnosis already made (``thermrs diagnose --json``, read with
        :meth:`thermrs.diagnose.result.Diagnosis.read`) of these runs; by default one is made
        when runs are held out.
    exclude
        Effects the diagnosis made here may not name (``thermrs diagnose --exclude``); with a
        ``diagnosis`` given, they must be the ones it excluded.
    title, step
        The report's title; called with a short description before each stage (progress).
    paper_reference
        Show the paper's printed Table 4 beside the runs' and predict along v, the paper's
        axis, with u beside it (the simulated paper runs).
    baselines
        Also the regressions of the drift on the temperatures, scored beside the diagnosis.

    Returns
    -------
    ReportData
        What :func:`thermrs.report.write_document` renders.

    Raises
    ------
    InputError
        No runs; two of one name; a training run not among them; a diagnosis of others.

    Examples
    --------
    >>> runs = thermrs.analyses.report_runs.load_runs("rec.mcap", rig)  # doctest: +SKIP
    >>> d = report_data(runs, rig, exclude=["thermal_lag"])  # doctest: +SKIP
    >>> d.diagnosis.to_json()["excluded"]  # doctest: +SKIP
    ['thermal_lag']
    """

    def say(what: str) -> None:
        if step is not None:
            step(what)

    split = report_split(runs, train)
    if diagnosis is not None:
        _check_given(diagnosis, split, rig, exclude)
    say("checking the rig")
    rig_view = rig.check()
    say("fitting α")
    fitted = _prediction(split, rig, paper_reference=paper_reference, say=say)
    say("fitting heating curves")
    drift = drift_tables([r.table for r in runs], window=ISO_WINDOW, tolerance_um=ISO_TOLERANCE_UM)
    diag, note = diagnosis, None
    if diag is None:
        diag, note = _diagnosis(split, rig, exclude, fitted.note, say)
    data = ReportData(
        rig=rig,
        rig_view=rig_view,
        runs=list(runs),
        train=split.train_names,
        holdout=split.holdout_names,
        fit=fitted.doc,
        fit_note=fitted.note,
        alphas=fitted.alphas,
        prediction=fitted.prediction,
        prediction_in_sample=not split.holdout,
        series=fitted.series,
        curves=drift.curves,
        iso=drift.iso.to_json(),
        iso_windows=drift.iso.windows,
        table4=table4(runs),
        diagnosis=diag,
        diagnosis_note=note,
        exclude=list(exclude),
        title=title or f"Thermal drift of {rig.name or rig.model}",
        paper_reference=paper_reference,
    )
    if diag is not None:
        _follow_diagnosis(data, diag, split, baselines=baselines, say=say)
    return data


def report_split(runs: Sequence[RunInput], train: Sequence[str] | None = None) -> Split:
    """The report's runs as a split: the training runs (by name; default the first run) and
    the others held out, in the order given.

    Raises
    ------
    InputError
        No runs, two runs of one name, or a training run that is not among them.
    """
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
    by = {r.name: r for r in runs}
    return Split(
        "",
        [by[n].table for n in train_names],
        [r.table for r in runs if r.name not in train_names],
        data_loss=any(r.data_loss for r in runs),
    )


def _check_given(diagnosis: Diagnosis, split: Split, rig: Rig, exclude: Sequence[str]) -> None:
    """A diagnosis given must be of these runs and rig, and have excluded what ``exclude``
    asks (one line, :class:`InputError`)."""
    diagnosis.check_runs(
        split.train_names, split.holdout_names, tables=[*split.train, *split.holdout], rig=rig
    )
    made = sorted(diagnosis_json(diagnosis).get("excluded") or [])
    if exclude and sorted(set(exclude)) != made:
        raise InputError(
            f"--exclude {' '.join(sorted(set(exclude)))}: the diagnosis given excluded "
            f"{', '.join(made) or 'nothing'}; give the diagnosis made with these exclusions, "
            "or no diagnosis"
        )


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


@dataclass
class _Fitted:
    """α fitted on the training runs and what it predicts (or why nothing was)."""

    doc: dict[str, Any] | None = None
    alphas: dict[str, float] = field(default_factory=dict)
    prediction: pl.DataFrame | None = None
    series: pl.DataFrame | None = None
    note: str | None = None


def _prediction(
    split: Split, rig: Rig, *, paper_reference: bool, say: Callable[[str], object]
) -> _Fitted:
    """α on the training runs and the held-out runs (else the training runs) predicted with
    it: ``thermrs predict``'s :class:`~thermrs.analyses.predict.Prediction`."""
    out = _Fitted()
    # Without held-out runs the training runs are predicted (in sample, said on the page).
    shown = split if split.holdout else Split(split.name, split.train, split.train)
    try:
        say("predicting")
        # The paper compares drift along its cameras' y axis (v): so does its demo, and along
        # x (u) beside it (`thermrs predict --axis u`), where the same α errs the other way.
        axis = "v" if paper_reference else "auto"
        (p,) = predict_splits([shown], rig, axis=axis)
        assert p.fit is not None
        out.doc = p.fit.to_json()
        out.alphas.update(p.alphas)
        out.prediction = p.table
        if axis == "v":
            (along_u,) = predict_splits([shown], rig, alphas=p.alphas, axis="u")
            out.prediction = pl.concat([p.table, along_u.table])
        out.series = p.series.filter(pl.col("alpha") == "series").drop("alpha")
    except InputError as e:
        out.note = f"α could not be fitted, so nothing was predicted: {e}."
    return out


def _diagnosis(
    split: Split,
    rig: Rig,
    exclude: Sequence[str],
    fit_note: str | None,
    say: Callable[[str], object],
) -> tuple[Diagnosis | None, str | None]:
    """The diagnosis ``thermrs diagnose`` makes of the split, or why none was made."""
    if fit_note is not None:
        return None, "No diagnosis: " + fit_note
    if not split.holdout:
        return None, (
            "One run only: a diagnosis needs runs held out from the fit, so none was made. "
            "Give more runs to diagnose where the nominal model falls short."
        )
    say("diagnosing")
    try:
        (fold,) = diagnose_splits([split], rig, exclude=exclude, workers=1)
    except ThermrsError as e:
        return None, f"The diagnosis could not be made: {e}"
    diagnosis: Diagnosis = fold.diagnosis
    return diagnosis, None


def _follow_diagnosis(
    data: ReportData,
    diag: Diagnosis,
    split: Split,
    *,
    baselines: bool,
    say: Callable[[str], object],
) -> None:
    """What the report shows that the diagnosis leads to, set on ``data``: the diagnosed
    prediction, the design of an ambiguous one (its rivals' drift, or why there is none) and,
    with ``baselines``, the regressions scored beside it."""
    data.diagnosed_prediction = _diagnosed_prediction(diag, split, data.rig)
    data.design, data.design_note = _design(split, data.rig, diag, say)
    data.design_drift = _rival_drift(data.design)
    if baselines and split.holdout:
        from thermrs.analyses.baselines import baselines_folds

        say("fitting the regressions beside the physical model")
        (data.baselines,) = baselines_folds([DiagnosisFold(split, diag)], data.rig)


def _diagnosed_prediction(diag: Diagnosis | None, split: Split, rig: Rig) -> pl.DataFrame | None:
    """With an identified effect, the held-out runs predicted by the nominal and the
    diagnosed model (``thermrs predict --diagnosis``'s table), else None."""
    if diag is None or not split.holdout:
        return None
    try:
        p = predict_diagnosed(split.holdout, rig, diagnosis_json(diag))
    except InputError:  # a diagnosis without the effect's α: nothing to predict with
        return None
    return p.shrink if p.model.effects else None


def _design(
    split: Split, rig: Rig, diag: Diagnosis, say: Callable[[str], object]
) -> tuple[DesignResult | None, str | None]:
    """For an ambiguous diagnosis, the experiment that settles it, as ``thermrs design
    --diagnosis`` designs it (or why there is none)."""
    from thermrs.analyses.design import design_splits

    doc = diagnosis_json(diag)
    if (doc.get("verdict") or {}).get("status") != "ambiguous":
        return None, None
    say("designing the experiment that settles it")
    try:
        (fold,) = design_splits(
            [split],
            rig,
            budget_h=DESIGN_BUDGET_H,
            diagnosis=diag,
            workers=1,
        )
    except ThermrsError as e:
        return None, f"No experiment could be designed: {e}"
    res: DesignResult = fold.result
    return (res, None) if res.confounded else (None, None)


def _rival_drift(designed: DesignResult | None) -> pl.DataFrame | None:
    """The designed experiment's rivals' forecast drift, or None."""
    if designed is None:
        return None
    from thermrs.design import rival_drift

    return rival_drift(designed)
