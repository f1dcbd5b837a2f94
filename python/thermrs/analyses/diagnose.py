"""``thermrs diagnose``: the sim-to-real gap diagnosed per split
(:func:`thermrs.diagnose.diagnose`: fitted on the training runs, scored on the held-out)."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from thermrs.analyses.folds import prefixed
from thermrs.analyses.inputs import DatasetLike, Split, check_splits, splits

__all__ = [
    "CLUSTER_FROM_VISITS",
    "DiagnosisFold",
    "Progress",
    "diagnose",
    "diagnose_splits",
    "fold_synthesis",
    "prefixed",
]

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


#: Visits (summed over the folds) from which :func:`diagnose_splits` starts a cluster of
#: its own for the folds. Measured on 2 cores (``benchmarks/bench_folds.py``): a cluster
#: takes about 4 s to start, and three folds of three 15-h runs (16,200 visits) took as long
#: on it as one after another here (15.1 against 15.6 s, where folds after the first reuse
#: the heating curves they share); six folds of six 8-h runs (34,560 visits) took 31 s
#: against 50 s.
CLUSTER_FROM_VISITS = 20_000


def diagnose_splits(
    sets: Sequence[Split],
    rig: Any,
    *,
    exclude: Sequence[str] = (),
    bootstrap: int = 30,
    seed: int = 0,
    margin_um: float | None = None,
    progress: Progress | None = None,
    client: Any = None,
    scheduler: str | None = None,
    workers: int | None = None,
) -> list[DiagnosisFold]:
    """A diagnosis per split: fitted on its training runs, scored on its held-out runs.

    Parameters
    ----------
    sets
        The splits (:func:`~thermrs.analyses.inputs.splits`,
        :func:`~thermrs.analyses.inputs.file_splits`); each must hold out a run.
    rig
        The rig (a :class:`~thermrs.rig.Rig` or its file).
    exclude, bootstrap, seed, margin_um, progress
        As :func:`thermrs.diagnose.diagnose` (``margin_um``: the practical margin;
        ``progress`` messages start with the fold).
    client, scheduler, workers
        Several splits are diagnosed side by side on Dask workers: a ``distributed.Client``,
        a scheduler's address, or the worker processes of a local cluster
        (:func:`thermrs.analyses.folds.map_folds`). With none given, a local cluster is
        started only from :data:`CLUSTER_FROM_VISITS` visits. The diagnoses are the same as
        one after another in this process.

    Returns
    -------
    list of DiagnosisFold
        One per split, in their order.

    Raises
    ------
    InputError
        A split without a held-out run, or holding out a training run again; runs the
        diagnoser refuses (:func:`thermrs.diagnose.input_checks.check_visits`), checked for every
        split before the first is diagnosed.

    Examples
    --------
    >>> sets = thermrs.analyses.file_splits(["rec.mcap#a"], ["rec.mcap#b"], rig)  # doctest: +SKIP
    >>> (d,) = thermrs.analyses.diagnose_splits(sets, rig)  # doctest: +SKIP
    >>> d.diagnosis.to_json()["verdict"]["status"]  # doctest: +SKIP
    """
    from thermrs.analyses.folds import run_folds
    from thermrs.diagnose import diagnose as diagnose_runs
    from thermrs.diagnose.input_checks import check_visits

    # Every split's runs checked before the first is diagnosed.
    check_splits(sets)
    for s in sets:
        check_visits(s.train, s.holdout)
    if workers is None and client is None and scheduler is None:
        if sum(t.height for s in sets for t in (*s.train, *s.holdout)) < CLUSTER_FROM_VISITS:
            workers = 1
    return run_folds(
        diagnose_runs,
        DiagnosisFold,
        sets,
        rig,
        client=client,
        scheduler=scheduler,
        workers=workers,
        progress=progress,
        exclude=list(exclude),
        bootstrap=bootstrap,
        seed=seed,
        margin_um=margin_um,
    )


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
    client: Any = None,
    scheduler: str | None = None,
    workers: int | None = None,
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
    client, scheduler, workers
        Where several folds are diagnosed side by side (a ``distributed.Client``, a
        scheduler's address, or the worker processes of the local cluster started:
        :func:`thermrs.analyses.folds.map_folds`; ``workers=1``: one after another here).

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
    >>> for d in thermrs.analyses.diagnose("campaign/", rig, rule="by-day"):  # doctest: +SKIP
    ...     print(d.split.name, d.diagnosis.to_json()["verdict"]["status"])
    """
    sets = splits(dataset, rig, where=where, rule=rule, train=train, holdout=holdout)
    return diagnose_splits(
        sets,
        rig,
        exclude=exclude,
        bootstrap=bootstrap,
        seed=seed,
        progress=progress,
        client=client,
        scheduler=scheduler,
        workers=workers,
    )


def fold_synthesis(docs: list[tuple[str, dict[str, Any]]]) -> dict[str, Any]:
    """What the folds of a rule conclude together (``thermrs diagnose --rule``'s
    ``synthesis``).

    Parameters
    ----------
    docs
        Per fold, its name and its ``thermrs diagnose --json`` document
        (:meth:`DiagnosisFold.to_json`'s ``diagnosis``).

    Returns
    -------
    dict
        ``tally`` (folds per verdict outcome), ``named`` (folds naming each effect: the
        verdict's, the confounded ones or a partial explanation's), ``leading`` (the effect
        named in most folds, or None), ``params`` (the leading effect's numeric parameters
        across the folds that identify it: ``median``, ``min``, ``max``, ``folds``),
        ``consistent`` (every fold the same outcome and, if any names one, the same leading
        effect) and ``sentence`` (the conclusion in words, naming where the folds disagree).

    Raises
    ------
    KeyError
        A document without a ``verdict``.

    Examples
    --------
    >>> from thermrs.analyses import fold_synthesis
    >>> none = {"verdict": {"status": "none"}}
    >>> fold_synthesis([("run1", none), ("run2", none)])["sentence"]
    'consistent across folds: none in all 2; no effect named in any fold'
    """
    from collections import Counter

    import numpy as np

    outcomes = {f: str(d["verdict"].get("outcome", d["verdict"]["status"])) for f, d in docs}
    tally = dict(Counter(outcomes.values()).most_common())
    named: Counter[str] = Counter()
    per_fold: dict[str, set[str]] = {}
    for f, d in docs:
        v = d["verdict"]
        names = {e for e in [v.get("effect"), *v.get("confounded_with", [])] if e}
        names |= set(v.get("effects", []))
        per_fold[f] = names
        named.update(names)
    leading = named.most_common(1)[0][0] if named else None
    values: dict[str, list[float]] = {}
    for _, d in docs:
        v = d["verdict"]
        if v.get("effect") != leading:
            continue
        for k, x in (v.get("params") or {}).items():
            if isinstance(x, int | float) and not isinstance(x, bool):
                values.setdefault(k, []).append(float(x))
    params = {
        k: {"median": float(np.median(x)), "min": min(x), "max": max(x), "folds": len(x)}
        for k, x in values.items()
    }
    n = len(docs)
    same_outcome = len(tally) == 1
    same_effect = leading is None or all(leading in s for s in per_fold.values())
    consistent = same_outcome and same_effect
    if consistent:
        what = f"{leading} named in every fold" if leading else "no effect named in any fold"
        sentence = f"consistent across folds: {next(iter(tally))} in all {n}; {what}"
    else:
        odd = [
            f"{f}: {outcomes[f]}" + (f" ({', '.join(sorted(per_fold[f]))})" if per_fold[f] else "")
            for f, _ in docs
            if outcomes[f] != next(iter(tally)) or (leading and leading not in per_fold[f])
        ]
        lead = f"{leading} named in {named[leading]} of {n} folds" if leading else "none named"
        sentence = (
            f"the folds disagree: {', '.join(f'{k} ×{c}' for k, c in tally.items())}; "
            f"{lead}; where: {'; '.join(odd)}"
        )
    if params:
        spread = ", ".join(
            f"{k} {p['median']:.4g} ({p['min']:.4g} – {p['max']:.4g} over {p['folds']} folds)"
            for k, p in params.items()
        )
        sentence += f"; {leading}'s parameters: {spread}"
    return {
        "tally": tally,
        "named": dict(named.most_common()),
        "leading": leading,
        "params": params,
        "consistent": consistent,
        "sentence": sentence,
    }
