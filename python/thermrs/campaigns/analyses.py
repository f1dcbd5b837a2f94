"""fit, predict, drift, diagnose and design on the runs of a campaign: the same library calls
the commands make on files (:mod:`thermrs.workflows`, :func:`thermrs.predict.prediction_table`,
:func:`thermrs.heating.heating_curves`, :func:`thermrs.diagnose.diagnose`,
:func:`thermrs.design.design`), once per :class:`~thermrs.campaigns.inputs.Split`.

Each function has two forms: ``*_splits`` takes splits however they were made (from a
dataset by :func:`~thermrs.campaigns.inputs.splits`, or from files by the CLI), and the short
form (:func:`fit`, :func:`predict`, :func:`drift`, :func:`diagnose`, :func:`design`) takes a
dataset, a query and a rule or run names.

Example
-------
>>> from thermrs import campaigns, load_rig
>>> rig = load_rig("rig.toml")  # doctest: +SKIP
>>> for p in campaigns.predict("campaign/", rig, where="speed>20", rule="leave-one-run-out"):
...     print(p.split.name, p.alphas["series"], p.table)  # doctest: +SKIP
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import polars as pl

from thermrs.campaigns.inputs import DatasetLike, Split, selected, splits

if TYPE_CHECKING:
    from thermrs.report import Written
    from thermrs.workflows import FitResult

__all__ = [
    "DesignFold",
    "DiagnosisFold",
    "DriftResult",
    "Prediction",
    "design",
    "design_splits",
    "diagnose",
    "diagnose_splits",
    "drift",
    "drift_tables",
    "fit",
    "predict",
    "predict_splits",
    "report",
]

Progress = Callable[[str], object]


def fit(
    dataset: DatasetLike, rig: Any, *, where: str | None = None, train: Sequence[str] = ()
) -> FitResult:
    """α over the runs ``where`` selects (or the ``train`` runs named among them), as
    ``thermrs fit --campaign`` reports it.

    Parameters
    ----------
    dataset
        The campaign dataset (a :class:`~thermrs.campaigns.Dataset` or its folder).
    rig
        The rig the runs were recorded on.
    where
        The query choosing runs (:func:`thermrs.campaigns.select.parse_query`; default all).
    train
        Runs by name, ``RECORDING#RUN`` or ``RECORDING`` (default: every run chosen).

    Returns
    -------
    FitResult
        :func:`thermrs.workflows.fit_document`: the time-series fit and start/end per run.

    Raises
    ------
    InputError
        Not a dataset; a bad query or one matching no run; a name naming no run; too few
        visits to fit (:func:`thermrs.fit.fit_alpha`).

    Examples
    --------
    >>> res = thermrs.campaigns.fit("campaign/", rig, where="date>=2026-11-02")  # doctest: +SKIP
    >>> res.fit.alpha_per_k, res.fit.ci95  # doctest: +SKIP
    """
    from thermrs.workflows import fit_document

    return fit_document(selected(dataset, rig, where=where, names=train).train, rig)


@dataclass(frozen=True)
class Prediction:
    """One split's prediction (``thermrs predict``).

    Attributes
    ----------
    split
        The training and held-out runs.
    alphas
        The α values predicted with, by label (:func:`thermrs.workflows.training_alphas`, or
        the α given).
    table
        :func:`thermrs.predict.prediction_table` of the held-out runs.
    series
        Every held-out visit's predicted and measured drift, per α (``alpha`` column: label).
    """

    split: Split
    alphas: dict[str, float]
    table: pl.DataFrame
    series: pl.DataFrame

    def centred_residuals(self, label: str = "series") -> Any:
        """Measured − predicted drift (µm) with the α labelled ``label`` over every held-out
        visit and both chip axes, each (run, camera, axis) series' mean removed (a numpy
        array)."""
        import numpy as np

        s = self.series.filter(pl.col("alpha") == label)
        parts = []
        for _, g in s.group_by(["run", "camera"], maintain_order=True):
            for a in "uv":
                r = g[f"residual_{a}_um"].to_numpy()
                r = r[np.isfinite(r)]
                if len(r):
                    parts.append(r - r.mean())
        return np.concatenate(parts) if parts else np.zeros(0)

    def rms_um(self, label: str = "series") -> float:
        """The held-out rms (µm) with the α labelled ``label``: the root mean square of
        :meth:`centred_residuals` — the definition of the per-run ``rms_centred_um``, pooled."""
        import numpy as np

        r = self.centred_residuals(label)
        return float(np.sqrt(np.mean(r**2))) if r.size else float("nan")

    def to_json(self) -> dict[str, Any]:
        """The ``thermrs predict --json`` document of this split (with its fold and runs)."""
        return {
            "fold": self.split.name,
            "train": self.split.train_names,
            "holdout": self.split.holdout_names,
            "alpha_per_k": self.alphas,
            "table": self.table.drop("alpha_per_k").to_dicts(),
        }


def predict_splits(
    sets: Sequence[Split],
    rig: Any,
    *,
    alphas: Mapping[str, float] | None = None,
    axis: str = "auto",
    end_visits: int = 1,
) -> list[Prediction]:
    """Per split, its held-out runs predicted with ``alphas`` or, without, with the α fitted
    on its training runs (:func:`thermrs.workflows.training_alphas`)."""
    from thermrs.predict import predict as run_predict
    from thermrs.predict import prediction_table
    from thermrs.workflows import fit_document, training_alphas, training_axes

    res = []
    for s in sets:
        doc = None if alphas else fit_document(s.train, rig)
        a = dict(alphas) if alphas else training_alphas(doc)  # type: ignore[arg-type]
        axes = {} if doc is None else training_axes(doc)
        table = prediction_table(
            s.holdout, rig, alphas=a, axis=axis, end_visits=end_visits, camera_axes=axes
        )
        joined = pl.concat(s.holdout, how="diagonal_relaxed")
        series = pl.concat(
            [
                run_predict(joined, rig, alpha_per_k=v).select(pl.lit(k).alias("alpha"), pl.all())
                for k, v in a.items()
            ]
        )
        res.append(Prediction(s, a, table, series))
    return res


def predict(
    dataset: DatasetLike,
    rig: Any,
    *,
    where: str | None = None,
    rule: str | None = None,
    train: Sequence[str] = (),
    runs: Sequence[str] = (),
    alpha_per_k: float | None = None,
    axis: str = "auto",
    end_visits: int = 1,
) -> list[Prediction]:
    """Held-out runs of a campaign predicted from their temperatures, as ``thermrs predict
    --campaign`` does.

    Parameters
    ----------
    dataset, rig, where
        As :func:`fit`.
    rule
        ``leave-one-run-out`` or ``by-day``: a prediction per fold, α fitted on its training
        runs.
    train
        Else the runs α is fitted on (names); ``runs`` default to the other runs chosen.
    runs
        The runs to predict (names; default: every run chosen that is not trained on).
    alpha_per_k
        Else predict with this α (1/K): no rule, no training runs.
    axis, end_visits
        As :func:`thermrs.predict.prediction_table`.

    Returns
    -------
    list of Prediction
        One per fold (one without a rule): the α values, the Table 7-style table, the series.

    Raises
    ------
    InputError
        What :func:`~thermrs.campaigns.inputs.splits` raises; α given with a rule or training
        runs; no run left to predict.

    Examples
    --------
    >>> folds = thermrs.campaigns.predict("campaign/", rig, rule="by-day")  # doctest: +SKIP
    >>> [(p.split.name, p.rms_um()) for p in folds]  # doctest: +SKIP
    """
    from thermrs.errors import InputError

    if alpha_per_k is not None:
        if rule or train:
            raise InputError("α given: no rule and no training runs")
        s = selected(dataset, rig, where=where, names=runs)
        sets = [Split("", [], s.train, s.data_loss)]
        return predict_splits(
            sets, rig, alphas={"given": alpha_per_k}, axis=axis, end_visits=end_visits
        )
    sets = splits(dataset, rig, where=where, rule=rule, train=train, holdout=runs)
    if any(not s.holdout for s in sets):
        raise InputError("no run left to predict: every selected run is a training run")
    return predict_splits(sets, rig, axis=axis, end_visits=end_visits)


@dataclass(frozen=True)
class DriftResult:
    """``thermrs drift``: heating curves (:func:`thermrs.heating.heating_curves`) and the ISO
    9283-style figures (:func:`thermrs.iso9283.iso9283`) of the runs."""

    curves: pl.DataFrame
    iso: Any

    def to_json(self) -> dict[str, Any]:
        """The ``thermrs drift --json`` document."""
        return {"curves": self.curves.to_dicts(), "iso9283": self.iso.to_json()}


def drift_tables(
    tables: Sequence[pl.DataFrame], *, window: int, tolerance_um: float
) -> DriftResult:
    """Heating curves and ISO 9283-style figures of run tables."""
    from thermrs.heating import heating_curves
    from thermrs.iso9283 import iso9283

    joined = pl.concat(tables, how="diagonal_relaxed")
    return DriftResult(
        heating_curves(joined), iso9283(joined, window=window, tolerance_um=tolerance_um)
    )


def drift(
    dataset: DatasetLike,
    rig: Any,
    *,
    where: str | None = None,
    runs: Sequence[str] = (),
    window: int | None = None,
    tolerance_um: float | None = None,
) -> DriftResult:
    """Heating curves and ISO 9283-style figures of a campaign's runs, as ``thermrs drift
    --campaign`` gives them.

    Parameters
    ----------
    dataset, rig, where
        As :func:`fit`.
    runs
        Runs by name among them (default: every run chosen).
    window, tolerance_um
        Visits per ISO 9283 window and the settling tolerance (µm); default as ``thermrs
        drift``'s.

    Returns
    -------
    DriftResult
        The curves and the ISO 9283-style figures.

    Raises
    ------
    InputError
        Not a dataset; a bad query or one matching no run; a name naming no run.

    Examples
    --------
    >>> d = thermrs.campaigns.drift("campaign/", rig, where="speed>20")  # doctest: +SKIP
    >>> d.iso.summary  # doctest: +SKIP
    """
    from thermrs.defaults import ISO_TOLERANCE_UM, ISO_WINDOW

    return drift_tables(
        selected(dataset, rig, where=where, names=runs).train,
        window=ISO_WINDOW if window is None else window,
        tolerance_um=ISO_TOLERANCE_UM if tolerance_um is None else tolerance_um,
    )


@dataclass(frozen=True)
class DiagnosisFold:
    """One split's diagnosis (:func:`thermrs.diagnose.diagnose`)."""

    split: Split
    diagnosis: Any

    def to_json(self) -> dict[str, Any]:
        """The split (fold, runs) and the ``thermrs diagnose --json`` document."""
        return {
            "fold": self.split.name,
            "train": self.split.train_names,
            "holdout": self.split.holdout_names,
            "diagnosis": self.diagnosis.to_json(),
        }


def diagnose_splits(
    sets: Sequence[Split],
    rig: Any,
    *,
    exclude: Sequence[str] = (),
    bootstrap: int = 30,
    seed: int = 0,
    margin_um: float | None = None,
    progress: Progress | None = None,
) -> list[DiagnosisFold]:
    """A diagnosis per split: fitted on its training runs, scored on its held-out runs
    (``margin_um``: the practical margin, :func:`thermrs.diagnose.diagnose`)."""
    from thermrs.diagnose import diagnose as run
    from thermrs.errors import InputError

    res = []
    for s in sets:
        if not s.holdout:
            raise InputError("no held-out run: effects are scored on runs they were not fitted on")
        say = None if progress is None else _prefixed(progress, s.name)
        d = run(
            s.train,
            s.holdout,
            rig,
            exclude=list(exclude),
            bootstrap=bootstrap,
            seed=seed,
            margin_um=margin_um,
            progress=say,
        )
        res.append(DiagnosisFold(s, d))
    return res


def _prefixed(progress: Progress, name: str) -> Progress:
    return progress if not name else lambda m: progress(f"{name}: {m}")


def diagnose(
    dataset: DatasetLike,
    rig: Any,
    *,
    where: str | None = None,
    rule: str | None = None,
    train: Sequence[str] = (),
    holdout: Sequence[str] = (),
    exclude: Sequence[str] = (),
    bootstrap: int = 30,
    seed: int = 0,
    progress: Progress | None = None,
) -> list[DiagnosisFold]:
    """The sim-to-real gap diagnosed on a campaign's runs, as ``thermrs diagnose
    --campaign`` does.

    Parameters
    ----------
    dataset, rig, where
        As :func:`fit`.
    rule
        ``leave-one-run-out`` or ``by-day``: a diagnosis per fold.
    train, holdout
        Else the runs named (see :func:`~thermrs.campaigns.inputs.splits`).
    exclude, bootstrap, seed, progress
        As :func:`thermrs.diagnose.diagnose` (``progress`` messages start with the fold).

    Returns
    -------
    list of DiagnosisFold
        One per fold (one without a rule).

    Raises
    ------
    InputError
        What :func:`~thermrs.campaigns.inputs.splits` and :func:`thermrs.diagnose.diagnose`
        raise; a split without held-out runs.

    Examples
    --------
    >>> for d in thermrs.campaigns.diagnose("campaign/", rig, rule="by-day"):  # doctest: +SKIP
    ...     print(d.split.name, d.diagnosis.to_json()["verdict"]["status"])
    """
    sets = splits(dataset, rig, where=where, rule=rule, train=train, holdout=holdout)
    return diagnose_splits(
        sets, rig, exclude=exclude, bootstrap=bootstrap, seed=seed, progress=progress
    )


@dataclass(frozen=True)
class DesignFold:
    """One split's design (:func:`thermrs.design.design`)."""

    split: Split
    result: Any


def design_splits(
    sets: Sequence[Split], rig: Any, *, progress: Progress | None = None, **options: Any
) -> list[DesignFold]:
    """A design per split; ``options`` are :func:`thermrs.design.design`'s keywords."""
    from thermrs.design import design as run

    res = []
    for s in sets:
        say = None if progress is None else _prefixed(progress, s.name)
        res.append(DesignFold(s, run(s.train, s.holdout, rig, progress=say, **options)))
    return res


def design(
    dataset: DatasetLike,
    rig: Any,
    *,
    where: str | None = None,
    rule: str | None = None,
    train: Sequence[str] = (),
    holdout: Sequence[str] = (),
    progress: Progress | None = None,
    **options: Any,
) -> list[DesignFold]:
    """The measurement that separates confounded effects, designed on a campaign's runs as
    ``thermrs design --campaign`` does.

    Parameters
    ----------
    dataset, rig, where
        As :func:`fit`.
    rule
        ``leave-one-run-out`` or ``by-day``: a design per fold.
    train, holdout
        Else the runs named, as for :func:`diagnose`.
    progress
        Called with a short message (starting with the fold) as the work goes on.
    **options
        :func:`thermrs.design.design`'s keywords (``exclude``, ``between``, ``budget_h``,
        ``seed``, ``prove_it``, …).

    Returns
    -------
    list of DesignFold
        One per fold (one without a rule); ``.result.write(DIR)`` writes its files.

    Raises
    ------
    InputError
        What :func:`~thermrs.campaigns.inputs.splits` and :func:`thermrs.design.design` raise.

    Examples
    --------
    >>> (d,) = thermrs.campaigns.design("campaign/", rig, train=["r1#run1"],
    ...                                 holdout=["r1#run2"], prove_it=False)  # doctest: +SKIP
    >>> d.result.write("next-experiment/")  # doctest: +SKIP
    """
    sets = splits(dataset, rig, where=where, rule=rule, train=train, holdout=holdout)
    return design_splits(sets, rig, progress=progress, **options)


def report(
    dataset: DatasetLike,
    rig: Any,
    out: str | Path,
    *,
    where: str | None = None,
    runs: Sequence[str] = (),
    train: Sequence[str] = (),
    **options: Any,
) -> Written:
    """The report a person reads, of a campaign's runs, as ``thermrs report --campaign``
    writes it.

    Parameters
    ----------
    dataset, rig, where
        As :func:`fit`.
    out
        The HTML file (the Markdown twin beside it, see :func:`thermrs.report.write_report`).
    runs
        The runs shown, by name (default: every run chosen).
    train
        The runs α is fitted on, by name (default: the first run); the others are held out,
        predicted and diagnosed.
    **options
        :func:`thermrs.report.write_report`'s keywords (``title``, ``markdown``, ``pdf``,
        ``step``, …).

    Returns
    -------
    Written
        What was written (:func:`thermrs.report.write_report`).

    Raises
    ------
    InputError
        Not a dataset; a bad query or one matching no run; a name naming no run.

    Examples
    --------
    >>> thermrs.campaigns.report("campaign/", rig, "november.html",
    ...                          where="date>=2026-11-01", train=["r1#run1"])  # doctest: +SKIP
    """
    from thermrs.report import write_report
    from thermrs.report.catalog import campaign_report_runs

    loaded, train_names = campaign_report_runs(dataset, rig, where=where, runs=runs, train=train)
    return write_report(out, runs=loaded, rig=rig, train=train_names or None, **options)
