"""Across a campaign, per run: α fitted on that run alone and the drift it showed (does the
robot change over weeks?), and the held-out check of a rule
(:func:`thermrs.campaigns.select.folds`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import polars as pl

from thermrs.campaigns.dataset import Dataset
from thermrs.campaigns.select import campaign_runs, folds, run_tables
from thermrs.moved import handed_on

__all__ = [
    "ALPHA_BY_RUN_SCHEMA",
    "HOLDOUT_SCHEMA",
    "CampaignSummary",
    "alpha_by_run",
    "alpha_trend",
    "by_group",
    "campaign_summary",
    "holdout_by_rule",
    "standouts",
]

#: Columns of :func:`alpha_by_run`. Fixed, not inferred from the rows: a campaign's first
#: hundred runs may all lack a speed (a robot that never moved) or a drift, and a type
#: inferred from them would refuse the next run's value.
ALPHA_BY_RUN_SCHEMA: dict[str, Any] = {
    "recording": pl.String,
    "run": pl.String,
    "date": pl.Date,
    "speed_deg_s": pl.Float64,
    "speed_pct": pl.Float64,
    "alpha_per_k": pl.Float64,
    "ci95_low": pl.Float64,
    "ci95_high": pl.Float64,
    "rms_um": pl.Float64,
    "visits": pl.Int64,
    "drift_um": pl.Float64,
    "start_ns": pl.Int64,
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
    """Per selected run: ``recording``, ``run``, ``date``, ``speed_deg_s``, ``speed_pct`` (the
    override, null where unknown: :func:`thermrs.campaigns.task.run_stats`), ``alpha_per_k``
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
                "speed_pct": r.get("speed_pct"),
                "alpha_per_k": f.alpha_per_k,
                "ci95_low": f.ci95[0],
                "ci95_high": f.ci95[1],
                "rms_um": f.rms_um,
                "visits": t.height,
                "drift_um": float(np.nanmax(drift)) if drift.size else None,
                "start_ns": r["start_ns"],
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


#: Seconds in a week: the trend's unit of time.
WEEK_S = 7 * 86_400.0


def alpha_trend(per_run: pl.DataFrame, *, level: float = 0.05) -> dict[str, Any]:
    """Does α change over the campaign? A straight line of each run's α against its start
    time, as a meta-regression: each run weighted by 1 / (its standard error² + τ²), its
    standard error from its 95 % interval, τ² the run-to-run variance the intervals do not
    carry (DerSimonian–Laird); the slope's variance with the modified Knapp–Hartung scale
    (never below 1) and a Student-t test with n − 2 degrees of freedom.

    Returns
    -------
    dict
        ``slope_per_k_per_week`` with ``ci95``, ``p``, ``runs``, ``span_days``, ``scale``,
        ``tau_per_k`` (√τ²) and ``sentence``: "α changed by x ± y ×10⁻⁶/K per week (p = …)"
        where the slope is significant at ``level``, else "no change in α above z ×10⁻⁶/K per
        week (95 %)"; ``None`` values and a sentence saying why where fewer than three runs
        or less than half a day.
    """
    from scipy import stats as st

    from thermrs.stats import lstsq_qr

    ok = per_run.filter(
        pl.col("alpha_per_k").is_not_null()
        & pl.col("start_ns").is_not_null()
        & (pl.col("ci95_high") > pl.col("ci95_low"))
    )
    n = ok.height
    t_s = ok["start_ns"].to_numpy().astype(np.float64) / 1e9 if n else np.zeros(0)
    span_days = float((t_s.max() - t_s.min()) / 86_400.0) if n else 0.0
    empty = {
        "slope_per_k_per_week": None,
        "ci95": None,
        "p": None,
        "runs": n,
        "span_days": span_days,
        "scale": None,
        "tau_per_k": None,
    }
    if n < 3 or span_days < 0.5:
        return {
            **empty,
            "sentence": f"no trend can be told from {n} run(s) over {span_days:.1f} days "
            "(at least three runs over half a day are needed)",
        }
    a = ok["alpha_per_k"].to_numpy()
    se = (ok["ci95_high"].to_numpy() - ok["ci95_low"].to_numpy()) / (2.0 * 1.959964)
    weeks = (t_s - t_s.mean()) / WEEK_S
    x = np.column_stack([np.ones(n), weeks])
    # Run-to-run differences the runs' own intervals do not carry: τ² by the method of
    # moments of meta-regression (DerSimonian–Laird), then the fit weighted by 1/(se² + τ²)
    # with the modified Knapp–Hartung scale (never below 1).
    w = 1.0 / se**2
    fixed = lstsq_qr(x, a, weights=w)
    q_stat = float(np.sum(w * fixed.residuals**2))
    xtwx_inv = np.linalg.inv(x.T @ (w[:, None] * x))
    c = float(np.sum(w) - np.trace(xtwx_inv @ (x.T @ ((w**2)[:, None] * x))))
    tau2 = max(0.0, (q_stat - (n - 2)) / c) if c > 0 else 0.0
    fit = lstsq_qr(x, a, weights=1.0 / (se**2 + tau2))
    scale = max(float(fit.sigma2), 1.0)
    # lstsq_qr's iid covariance is s²·(XᵀWX)⁻¹: the known-variance one times the scale used.
    var = float(fit.cov[1, 1]) / float(fit.sigma2) * scale
    slope, sd = float(fit.coef[1]), float(np.sqrt(var))
    dof = n - 2
    q = float(st.t.ppf(0.975, dof))
    ci = [slope - q * sd, slope + q * sd]
    p = float(2.0 * st.t.sf(abs(slope) / sd, dof)) if sd > 0 else 0.0
    if p < level:
        sentence = (
            f"α changed by {slope * 1e6:+.3f} ± {q * sd * 1e6:.3f} ×10⁻⁶/K per week "
            f"(95 %; p = {p:.2g}; {n} runs over {span_days:.1f} days)"
        )
    else:
        bound = max(abs(ci[0]), abs(ci[1]))
        sentence = (
            f"no change in α above {bound * 1e6:.3f} ×10⁻⁶/K per week (95 %; slope "
            f"{slope * 1e6:+.3f} ×10⁻⁶/K per week, p = {p:.2g}; {n} runs over "
            f"{span_days:.1f} days)"
        )
    return {
        "slope_per_k_per_week": slope,
        "ci95": ci,
        "p": p,
        "runs": n,
        "span_days": span_days,
        "scale": scale,
        "tau_per_k": float(np.sqrt(tau2)),
        "sentence": sentence,
    }


def speed_axis(per_run: pl.DataFrame) -> tuple[str, str]:
    """The speed a campaign's runs are compared by: ``("speed_pct", "%")``, the override, when
    every run's is known; else ``("speed_deg_s", "°/s")``, the 95th-percentile joint speed."""
    if "speed_pct" in per_run.columns and per_run["speed_pct"].null_count() == 0:
        return "speed_pct", "%"
    return "speed_deg_s", "°/s"


def by_group(per_run: pl.DataFrame, key: str) -> pl.DataFrame:
    """Per day (``key="date"``) or per speed (``key="speed"``: the override in bins of 10 %
    where every run's is known, else the 95th-percentile joint speed in bins of 10 °/s, see
    :func:`speed_axis`): runs, α's mean and range, and the drift envelope (the largest and the
    mean of the runs' largest drifts)."""
    if key == "speed":
        # By override (bins of 10 %) where every run's is known, else by joint speed (10 °/s).
        col, unit = speed_axis(per_run)
        grouped = per_run.with_columns(
            group=pl.when(pl.col(col).is_null())
            .then(pl.lit("unknown"))
            .otherwise(
                ((pl.col(col) // 10) * 10).cast(pl.Int64).cast(pl.String)
                + "–"
                + ((pl.col(col) // 10) * 10 + 10).cast(pl.Int64).cast(pl.String)
                + f" {unit}"
            ),
            order=pl.col(col).fill_null(1e9),
        )
    elif key == "date":
        grouped = per_run.with_columns(
            group=pl.col("date").cast(pl.String), order=pl.col("date").cast(pl.Int64)
        )
    else:
        raise ValueError(f"group by 'date' or 'speed', not {key!r}")
    return (
        grouped.group_by("group")
        .agg(
            runs=pl.len(),
            alpha_mean=pl.col("alpha_per_k").mean(),
            alpha_min=pl.col("alpha_per_k").min(),
            alpha_max=pl.col("alpha_per_k").max(),
            drift_max_um=pl.col("drift_um").max(),
            drift_mean_um=pl.col("drift_um").mean(),
            order=pl.col("order").min(),
        )
        .sort("order")
        .drop("order")
    )


#: A run stands out when its α lies this many standard errors (its own and the campaign's
#: scatter combined) from the campaign's weighted mean.
STANDOUT_Z = 3.0


def standouts(per_run: pl.DataFrame) -> list[dict[str, Any]]:
    """The runs that stand out, each with why: an α more than :data:`STANDOUT_Z` standard
    errors from the others' weighted mean (its own interval and the others' scatter), or a
    largest drift beyond the others' upper quartile plus three interquartile ranges."""
    out: list[dict[str, Any]] = []
    rows = list(per_run.iter_rows(named=True))
    if len(rows) < 4:
        return out
    a = np.array([r["alpha_per_k"] for r in rows], dtype=np.float64)
    se = np.array(
        [(r["ci95_high"] - r["ci95_low"]) / (2 * 1.959964) for r in rows], dtype=np.float64
    )
    d = np.array([np.nan if r["drift_um"] is None else r["drift_um"] for r in rows])
    for i, r in enumerate(rows):
        others = np.arange(len(rows)) != i
        w = 1.0 / se[others] ** 2
        mean = float(np.sum(w * a[others]) / np.sum(w))
        spread = float(np.std(a[others], ddof=1))
        z = (a[i] - mean) / np.hypot(se[i], spread)
        why = []
        if abs(z) > STANDOUT_Z:
            why.append(
                f"α {a[i] * 1e6:.2f} ×10⁻⁶/K is {abs(z):.1f} standard errors "
                f"{'above' if z > 0 else 'below'} the other runs' {mean * 1e6:.2f}"
            )
        od = d[others][np.isfinite(d[others])]
        if np.isfinite(d[i]) and len(od) >= 3:
            q1, q3 = np.percentile(od, [25, 75])
            if d[i] > q3 + 3.0 * (q3 - q1):
                why.append(
                    f"its largest drift {d[i]:.1f} µm is beyond the other runs' "
                    f"{q3:.1f} µm upper quartile by more than three interquartile ranges"
                )
        if why:
            out.append({"recording": r["recording"], "run": r["run"], "why": "; ".join(why)})
    return out


@dataclass(frozen=True)
class CampaignSummary:
    """What ``thermrs campaign`` prints and its page shows, computed once.

    Attributes
    ----------
    per_run
        α and the largest drift per run (:func:`alpha_by_run`).
    trend
        α's trend over time (:func:`alpha_trend`).
    standouts
        The runs that stand out (:func:`standouts`).
    by_day, by_speed
        Per day and per speed (:func:`by_group`).
    speed
        The speed the runs are compared by: its column and unit (:func:`speed_axis`).
    folds
        The held-out check of a rule (:func:`holdout_by_rule`), or None.
    """

    per_run: pl.DataFrame
    trend: dict[str, Any]
    standouts: list[dict[str, Any]]
    by_day: pl.DataFrame
    by_speed: pl.DataFrame
    speed: tuple[str, str]
    folds: pl.DataFrame | None = None


def campaign_summary(
    per_run: pl.DataFrame, *, folds: pl.DataFrame | None = None
) -> CampaignSummary:
    """Everything ``thermrs campaign`` says of its runs (:class:`CampaignSummary`).

    Parameters
    ----------
    per_run
        :func:`alpha_by_run`'s table.
    folds
        :func:`holdout_by_rule`'s table, if a rule was given.

    Returns
    -------
    CampaignSummary
        The trend, the runs that stand out, the per-day and per-speed tables.

    Examples
    --------
    >>> s = campaign_summary(alpha_by_run(ds, rig))  # doctest: +SKIP
    >>> s.trend["sentence"]  # doctest: +SKIP
    """
    return CampaignSummary(
        per_run=per_run,
        trend=alpha_trend(per_run),
        standouts=standouts(per_run),
        by_day=by_group(per_run, "date"),
        by_speed=by_group(per_run, "speed"),
        speed=speed_axis(per_run),
        folds=folds,
    )


#: Names that moved to :mod:`thermrs.analyses`, each with the module that defines it there
#: (handed on when first asked, with a warning; this module imports nothing of it).
MOVED_TO_ANALYSES = {
    "fold_synthesis": "thermrs.analyses.diagnose",
    "predict_synthesis": "thermrs.analyses.predict",
}


__getattr__ = handed_on("thermrs.campaigns.summary", MOVED_TO_ANALYSES)
