"""``thermrs report --campaign``: the report a person reads, of a campaign's runs."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from thermrs.analyses.inputs import DatasetLike

if TYPE_CHECKING:
    from thermrs.report import Written

__all__ = ["report"]


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
