"""The folds' synthesis: what several folds' diagnoses conclude together, on documents whose
verdicts are known."""

from __future__ import annotations

from typing import Any

import pytest
from thermrs.analyses.diagnose import fold_synthesis


def _doc(status: str, effect: str | None, **params: Any) -> dict[str, Any]:
    return {
        "verdict": {
            "status": status,
            "outcome": status,
            "effect": effect,
            "params": params,
            "confounded_with": [],
            "effects": [effect] if effect else [],
        }
    }


def test_folds_that_agree_are_said_to() -> None:
    s = fold_synthesis(
        [
            ("without r1", _doc("identified", "thermal_lag", tau_min=40.0)),
            ("without r2", _doc("identified", "thermal_lag", tau_min=50.0)),
            ("without r3", _doc("identified", "thermal_lag", tau_min=45.0)),
        ]
    )
    assert s["consistent"] and s["leading"] == "thermal_lag"
    assert s["tally"] == {"identified": 3}
    assert s["params"]["tau_min"] == {"median": 45.0, "min": 40.0, "max": 50.0, "folds": 3}
    assert s["sentence"].startswith("consistent across folds: identified in all 3")


def test_folds_that_disagree_say_where() -> None:
    s = fold_synthesis(
        [
            ("without r1", _doc("identified", "thermal_lag", tau_min=40.0)),
            ("without r2", _doc("none", None)),
            ("without r3", _doc("identified", "thermal_lag", tau_min=60.0)),
        ]
    )
    assert not s["consistent"]
    assert s["named"] == {"thermal_lag": 2}
    assert "the folds disagree: identified ×2, none ×1" in s["sentence"]
    assert "thermal_lag named in 2 of 3 folds" in s["sentence"]
    assert "without r2: none" in s["sentence"] and "without r1:" not in s["sentence"]


def test_no_effect_anywhere_is_consistent() -> None:
    s = fold_synthesis([("a", _doc("none", None)), ("b", _doc("none", None))])
    assert s["consistent"] and s["leading"] is None and s["params"] == {}
    assert "no effect named in any fold" in s["sentence"]


def _campaign(
    rng: Any, *, slope_per_week: float, extra_sd: float, n: int = 20, days: float = 10.0
) -> Any:
    """Per-run α of a simulated campaign: ``n`` runs over ``days``, α 11.5×10⁻⁶/K changing by
    ``slope_per_week``, each run's estimate scattered by its own standard error (0.05–0.15)
    and by ``extra_sd`` more (run-to-run differences its interval does not carry)."""
    import datetime

    import numpy as np
    import polars as pl

    t_s = np.sort(rng.uniform(0, days * 86_400, n)) + 1.75e9
    se = rng.uniform(0.05, 0.15, n) * 1e-6
    true = 11.5e-6 + slope_per_week * (t_s - t_s[0]) / (7 * 86_400)
    a = true + rng.standard_normal(n) * np.hypot(se, extra_sd)
    return pl.DataFrame(
        {
            "recording": [f"r{i}" for i in range(n)],
            "run": ["run1"] * n,
            "date": [datetime.date.fromtimestamp(x) for x in t_s],
            "speed_deg_s": rng.choice([40.0, 100.0], n),
            "alpha_per_k": a,
            "ci95_low": a - 1.96 * se,
            "ci95_high": a + 1.96 * se,
            "rms_um": [1.0] * n,
            "visits": [100] * n,
            "drift_um": rng.uniform(20, 40, n),
            "start_ns": (t_s * 1e9).astype(np.int64),
        }
    )


@pytest.mark.slow
def test_the_trend_interval_covers_the_true_slope() -> None:
    """Over 400 simulated campaigns with a known trend (and run-to-run scatter beyond the runs'
    intervals), the slope's 95 % interval covers the truth at close to 95 %, and a campaign
    without a trend is said to change in close to 5 %."""
    import numpy as np
    from thermrs.campaigns.summary import alpha_trend

    rng = np.random.default_rng(20261128)
    for slope, extra in ((0.3e-6, 0.0), (0.3e-6, 0.1e-6), (0.0, 0.1e-6)):
        cover = changed = 0
        for _ in range(400):
            t = alpha_trend(_campaign(rng, slope_per_week=slope, extra_sd=extra))
            lo, hi = t["ci95"]
            cover += lo <= slope <= hi
            changed += t["sentence"].startswith("α changed by")
        # Binomial(400, 0.95): 2.5 standard deviations is 0.919.
        assert 0.92 <= cover / 400 <= 0.98, (slope, extra, cover)
        if slope == 0.0:
            assert changed / 400 <= 0.08, changed
            assert t["sentence"].startswith("no change in α above")
        else:
            assert changed / 400 >= 0.9, changed


def test_groups_and_standouts() -> None:
    import numpy as np
    import polars as pl
    from thermrs.campaigns.summary import by_group, standouts

    rng = np.random.default_rng(7)
    per_run = _campaign(rng, slope_per_week=0.0, extra_sd=0.0, n=12)
    per_run = per_run.with_columns(
        alpha_per_k=pl.when(pl.col("recording") == "r5")
        .then(pl.col("alpha_per_k") + 2e-6)
        .otherwise(pl.col("alpha_per_k"))
    ).with_columns(ci95_low=pl.col("alpha_per_k") - 1e-7, ci95_high=pl.col("alpha_per_k") + 1e-7)
    out = standouts(per_run)
    assert [o["recording"] for o in out] == ["r5"] and "above" in out[0]["why"]
    speeds = by_group(per_run, "speed")
    assert speeds["group"].to_list() == ["40–50 °/s", "100–110 °/s"]
    assert speeds["runs"].sum() == 12
    assert speeds["drift_max_um"].to_list() == [
        per_run.filter(pl.col("speed_deg_s") == s)["drift_um"].max() for s in (40.0, 100.0)
    ]
    days = by_group(per_run, "date")
    assert days["runs"].sum() == 12 and days["group"].to_list() == sorted(days["group"])
