"""``thermrs design``: the measurement that separates confounded effects, designed per split
(:func:`thermrs.design.design`)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from thermrs.analyses.diagnose import Progress
from thermrs.analyses.inputs import DatasetLike, Split, splits

__all__ = ["DesignFold", "design", "design_splits"]


@dataclass(frozen=True)
class DesignFold:
    """One split's design (:func:`thermrs.design.design`)."""

    split: Split
    result: Any


def design_splits(
    sets: Sequence[Split],
    rig: Any,
    *,
    progress: Progress | None = None,
    client: Any = None,
    scheduler: str | None = None,
    workers: int | None = None,
    **options: Any,
) -> list[DesignFold]:
    """A design per split (:func:`thermrs.design.design` on its training and held-out runs).

    Parameters
    ----------
    sets
        The splits (:func:`~thermrs.analyses.inputs.splits`,
        :func:`~thermrs.analyses.inputs.file_splits`).
    rig
        The rig (a :class:`~thermrs.rig.Rig` or its file).
    progress
        Called with a short message (starting with the fold) as the work goes on.
    client, scheduler, workers
        Several splits are designed side by side on Dask workers: a ``distributed.Client``,
        a scheduler's address, or the worker processes of a local cluster
        (:func:`thermrs.analyses.folds.map_folds`).
    **options
        :func:`thermrs.design.design`'s keywords (``exclude``, ``between``, ``budget_h``,
        ``seed``, ``prove_it``, …).

    Returns
    -------
    list of DesignFold
        One per split, in their order.

    Raises
    ------
    InputError
        What :func:`thermrs.design.design` raises.

    Examples
    --------
    >>> sets = thermrs.analyses.file_splits(["rec.mcap#a"], ["rec.mcap#b"], rig)  # doctest: +SKIP
    >>> (d,) = thermrs.analyses.design_splits(sets, rig, prove_it=False)  # doctest: +SKIP
    """
    from thermrs.analyses.folds import run_folds
    from thermrs.design import design as design_runs

    return run_folds(
        design_runs,
        DesignFold,
        sets,
        rig,
        client=client,
        scheduler=scheduler,
        workers=workers,
        progress=progress,
        **options,
    )


def design(
    dataset: DatasetLike,
    rig: Any,
    *,
    where: str | None = None,
    rule: str | None = None,
    train: Sequence[str] = (),
    holdout: Sequence[str] = (),
    progress: Progress | None = None,
    client: Any = None,
    scheduler: str | None = None,
    workers: int | None = None,
    **options: Any,
) -> list[DesignFold]:
    """The measurement that separates confounded effects, designed on a campaign's runs as
    ``thermrs design --campaign`` does.

    Parameters
    ----------
    dataset, rig, where
        As :func:`thermrs.analyses.fit.fit`.
    rule
        ``leave-one-run-out`` or ``by-day``: a design per fold.
    train, holdout
        Else the runs named, as for :func:`thermrs.analyses.diagnose.diagnose`.
    progress
        Called with a short message (starting with the fold) as the work goes on.
    client, scheduler, workers
        Where several folds are designed side by side, as for
        :func:`thermrs.analyses.diagnose.diagnose`.
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
        What :func:`~thermrs.analyses.inputs.splits` and :func:`thermrs.design.design` raise.

    Examples
    --------
    >>> (d,) = thermrs.analyses.design("campaign/", rig, train=["r1#run1"],
    ...                                 holdout=["r1#run2"], prove_it=False)  # doctest: +SKIP
    >>> d.result.write("next-experiment/")  # doctest: +SKIP
    """
    sets = splits(dataset, rig, where=where, rule=rule, train=train, holdout=holdout)
    return design_splits(
        sets,
        rig,
        progress=progress,
        client=client,
        scheduler=scheduler,
        workers=workers,
        **options,
    )
