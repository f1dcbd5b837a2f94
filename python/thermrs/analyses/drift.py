"""``thermrs drift``: heating curves and ISO 9283-style figures of runs."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import polars as pl

from thermrs.analyses.inputs import DatasetLike, selected

__all__ = ["DriftResult", "drift", "drift_tables"]


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
    """Heating curves and ISO 9283-style figures of run tables.

    Parameters
    ----------
    tables
        Run tables (:func:`thermrs.runs.load_runs`, :func:`~thermrs.analyses.inputs.file_tables`).
    window
        Visits per ISO 9283 window, per camera and run (:func:`thermrs.iso9283.iso9283`).
    tolerance_um
        The settling tolerance (µm).

    Returns
    -------
    DriftResult
        The curves and the figures, as ``thermrs drift`` prints them.

    Raises
    ------
    InputError
        What :func:`thermrs.heating.heating_curves` and :func:`thermrs.iso9283.iso9283` raise.

    Examples
    --------
    >>> tables = thermrs.runs.load_runs("rec.mcap", rig).tables  # doctest: +SKIP
    >>> thermrs.analyses.drift_tables(tables, window=5, tolerance_um=5.0).curves  # doctest: +SKIP
    """
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
        As :func:`thermrs.analyses.fit.fit`.
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
    >>> d = thermrs.analyses.drift("campaign/", rig, where="speed>20")  # doctest: +SKIP
    >>> d.iso.summary  # doctest: +SKIP
    """
    from thermrs.defaults import ISO_TOLERANCE_UM, ISO_WINDOW

    return drift_tables(
        selected(dataset, rig, where=where, names=runs).train,
        window=ISO_WINDOW if window is None else window,
        tolerance_um=ISO_TOLERANCE_UM if tolerance_um is None else tolerance_um,
    )
