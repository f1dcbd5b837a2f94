"""``thermrs diagnose``: the sim-to-real gap diagnosed per split
(:func:`thermrs.diagnose.diagnose`: fitted on the training runs, scored on the held-out)."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from thermrs.analyses.inputs import DatasetLike, Split, splits

__all__ = ["DiagnosisFold", "Progress", "diagnose", "diagnose_splits", "prefixed"]

#: Called with a short message as the work goes on.
Progress = Callable[[str], object]


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
    from thermrs.diagnose import diagnose as diagnose_runs
    from thermrs.diagnose.inputs import check_visits
    from thermrs.errors import InputError

    # Every split's runs checked before the first is diagnosed.
    for s in sets:
        if not s.holdout:
            raise InputError("no held-out run: effects are scored on runs they were not fitted on")
        check_visits(s.train, s.holdout)
    res = []
    for s in sets:
        say = None if progress is None else prefixed(progress, s.name)
        d = diagnose_runs(
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


def prefixed(progress: Progress, name: str) -> Progress:
    """``progress`` with each message prefixed by the fold's name (as is without one)."""
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
        As :func:`thermrs.analyses.fit.fit`.
    rule
        ``leave-one-run-out`` or ``by-day``: a diagnosis per fold.
    train, holdout
        Else the runs named (see :func:`~thermrs.analyses.inputs.splits`).
    exclude, bootstrap, seed, progress
        As :func:`thermrs.diagnose.diagnose` (``progress`` messages start with the fold).

    Returns
    -------
    list of DiagnosisFold
        One per fold (one without a rule).

    Raises
    ------
    InputError
        What :func:`~thermrs.analyses.inputs.splits` and :func:`thermrs.diagnose.diagnose`
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
