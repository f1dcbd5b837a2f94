"""``thermrs fit``: α fitted on training runs (:func:`thermrs.fit.fit_document`, the SPEC §7
``thermrs fit --json`` document), and :func:`fit`, the same on the runs of a campaign dataset
chosen by query or name. :func:`~thermrs.fit.training_alphas` and
:func:`~thermrs.fit.training_axes` (the α values and axes a prediction from training runs
uses) are handed on from :mod:`thermrs.fit`.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from thermrs.analyses.inputs import DatasetLike, selected
from thermrs.fit import FitResult, fit_document, training_alphas, training_axes

__all__ = ["FitResult", "fit", "fit_document", "training_alphas", "training_axes"]


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
    >>> res = thermrs.analyses.fit("campaign/", rig, where="date>=2026-11-02")  # doctest: +SKIP
    >>> res.fit.alpha_per_k, res.fit.ci95  # doctest: +SKIP
    """
    return fit_document(selected(dataset, rig, where=where, names=train).train, rig)
