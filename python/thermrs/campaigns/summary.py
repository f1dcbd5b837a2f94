"""Across a campaign, per run: α fitted on that run alone and the drift it showed (does the
robot change over weeks?), and the held-out check of a rule
(:func:`thermrs.campaigns.select.folds`).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import polars as pl

from thermrs.campaigns.dataset import Dataset
from thermrs.campaigns.select import campaign_runs, folds, run_tables

__all__ = [
    "ALPHA_BY_RUN_SCHEMA",
    "HOLDOUT_SCHEMA",
    "alpha_by_run",
    "fold_synthesis",
    "holdout_by_rule",
]

#: Columns of :func:`alpha_by_run`. Fixed, not inferred from the rows: a campaign's first
#: hundred runs may all lack a speed (a robot that never moved) or a drift, and a type
#: inferred from them would refuse the next run's value.
ALPHA_BY_RUN_SCHEMA: dict[str, Any] = {
    "recording": pl.String,
    "run": pl.String,
    "date": pl.Date,
    "speed_deg_s": pl.Float64,
    "alpha_per_k": pl.Float64,
    "ci95_low": pl.Float64,
    "ci95_high": pl.Float64,
    "rms_um": pl.Float64,
    "visits": pl.Int64,
    "drift_um": pl.Float64,
}

#: Columns of :func:`holdout_by_rule`.
HOLDOUT_SCHEMA: dict[str, Any] = {
    "fold": pl.String,
    "train_runs": pl.Int64,
    "holdout_runs": pl.Int64,
    "alpha_per_k": pl.Float64,
    "holdout_rms_um": pl.Float64,
}


def alpha_by_run(dataset: Dataset, rig: Any, *, query: str | None = None) -> pl.DataFrame:
    """Per selected run: ``recording``, ``run``, ``date``, ``speed_deg_s``, ``alpha_per_k``
    with ``ci95_low``/``ci95_high`` (the time-series fit of :func:`thermrs.fit.fit_alpha` on
    that run alone), ``rms_um``, ``visits`` and ``drift_um``: the largest drift of a spot from
    its camera's first visit in the run (µm, the norm of u and v)."""
    from thermrs.fit import fit_alpha

    runs = campaign_runs(dataset, query)
    tables = run_tables(dataset, runs, rig)
    rows = []
    for r, t in zip(runs.iter_rows(named=True), tables, strict=True):
        f = fit_alpha([t], rig)
        drift = np.hypot(t["drift_u_um"].to_numpy(), t["drift_v_um"].to_numpy())
        rows.append(
            {
                "recording": r["recording"],
                "run": r["run"],
                "date": r["date"],
                "speed_deg_s": r["speed_deg_s"],
                "alpha_per_k": f.alpha_per_k,
                "ci95_low": f.ci95[0],
                "ci95_high": f.ci95[1],
                "rms_um": f.rms_um,
                "visits": t.height,
                "drift_um": float(np.nanmax(drift)) if drift.size else None,
            }
        )
    return pl.DataFrame(rows, schema=ALPHA_BY_RUN_SCHEMA)


def holdout_by_rule(
    dataset: Dataset, rig: Any, *, rule: str, query: str | None = None
) -> pl.DataFrame:
    """Per fold of ``rule``: α fitted on the training runs and the RMS (µm, over visits, the
    norm of u and v) of measured minus predicted drift on the held-out runs
    (:func:`thermrs.predict.predict` with that α)."""
    from thermrs.fit import fit_alpha
    from thermrs.predict import predict

    runs = campaign_runs(dataset, query)
    tables = dict(
        zip(
            [f"{a}#{b}" for a, b in zip(runs["recording"], runs["run"], strict=True)],
            run_tables(dataset, runs, rig),
            strict=True,
        )
    )
    rows = []
    for fold in folds(runs, rule):
        f = fit_alpha([tables[n] for n in fold.train], rig)
        p = predict(pl.concat([tables[n] for n in fold.holdout]), rig, alpha_per_k=f.alpha_per_k)
        res = np.hypot(p["residual_u_um"].to_numpy(), p["residual_v_um"].to_numpy())
        rows.append(
            {
                "fold": fold.name,
                "train_runs": len(fold.train),
                "holdout_runs": len(fold.holdout),
                "alpha_per_k": f.alpha_per_k,
                "holdout_rms_um": float(np.sqrt(np.nanmean(res**2))),
            }
        )
    return pl.DataFrame(rows, schema=HOLDOUT_SCHEMA)


def fold_synthesis(docs: list[tuple[str, dict[str, Any]]]) -> dict[str, Any]:
    """What the folds of a rule conclude together, from each fold's ``thermrs diagnose
    --json`` document (``(fold name, document)``).

    Returns
    -------
    dict
        ``tally`` (folds per verdict outcome), ``named`` (folds naming each effect: the
        verdict's, the confounded ones or a partial explanation's), ``leading`` (the effect
        named in most folds, or None), ``params`` (the leading effect's numeric parameters
        across the folds that identify it: ``median``, ``min``, ``max``, ``folds``),
        ``consistent`` (every fold the same outcome and, if any names one, the same leading
        effect) and ``sentence`` (the conclusion in words, naming where the folds disagree).
    """
    from collections import Counter

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
