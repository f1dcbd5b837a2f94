"""``thermrs fit``: α fitted on training runs, and which α a prediction from training runs uses.

- :func:`fit`: the same on the runs of a campaign dataset, chosen by query or name;
- :func:`fit_document`: α's time-series fit over the training runs and, beside it, the paper's
  start/end estimator per run: the SPEC §7 ``thermrs fit --json`` document (extended).
- :func:`training_alphas`: the labelled α values a prediction from training runs uses:
  ``series`` (the time-series fit) and, with one training run (the paper's protocol), its
  start/end α per camera and their ``mean``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import polars as pl

from thermrs.analyses.inputs import DatasetLike, selected
from thermrs.fit import AlphaFit, RigLike, StartEndFit, fit_alpha, fit_alpha_start_end

__all__ = ["FitResult", "fit", "fit_document", "training_alphas", "training_axes"]


@dataclass(frozen=True)
class FitResult:
    """α fitted on training runs, both estimators (see :func:`fit_document`)."""

    fit: AlphaFit
    start_end: dict[str, StartEndFit]

    def to_json(self) -> dict[str, Any]:
        """The ``thermrs fit --json`` document: the time-series fit with ``start_end`` per run."""
        doc = self.fit.to_json()
        doc["start_end"] = {run: se.to_json() for run, se in self.start_end.items()}
        return doc


def fit_document(tables: Sequence[pl.DataFrame], rig: RigLike) -> FitResult:
    """Fit α over ``tables`` (time series) and per table with the paper's start/end estimator.

    Raises
    ------
    InputError
        Too few visits, or a table that is not a run table (see :func:`thermrs.fit.fit_alpha`).
    """
    f = fit_alpha(tables, rig)
    return FitResult(f, {str(t["run"][0]): fit_alpha_start_end(t, rig) for t in tables})


def training_alphas(result: FitResult) -> dict[str, float]:
    """The α values a prediction from the training runs uses (see the module docstring)."""
    alphas = {"series": result.fit.alpha_per_k}
    if len(result.start_end) == 1:  # the paper's protocol: α per camera and their mean
        se = next(iter(result.start_end.values()))
        for cam, (a, _) in se.per_camera.items():
            alphas[cam] = a
        alphas["mean"] = se.mean[0]
    return alphas


def training_axes(result: FitResult) -> dict[str, str]:
    """The chip axis each camera's start/end α was taken along (the paper's protocol: one
    training run), by camera: its Table 7 rows are judged along that axis."""
    if len(result.start_end) != 1:
        return {}
    return dict(next(iter(result.start_end.values())).axes)


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
        :func:`thermrs.analyses.fit.fit_document`: the time-series fit and start/end per run.

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
    return fit_document(selected(dataset, rig, where=where, names=train).train, rig)
