"""The bound on strict identification (:mod:`thermrs.bench.world.separability`) against what
it must be whatever the code: a rival family that holds the truth cannot be rejected beyond the
test's level (Neyman–Pearson: equal means, power = level), a rival far from it always is, and
the power of the most powerful test, simulated with the world's own noise, is the bound's."""

from __future__ import annotations

import numpy as np
import pytest
import thermrs
from scipy.stats import norm
from thermrs.bench.world import Campaign, Truth, draw_scene, render
from thermrs.bench.world.cases import case_rigs
from thermrs.bench.world.separability import (
    guarded_power_bound,
    rival_members,
    strict_power_bound,
)
from thermrs.bench.world.snr import stack
from thermrs.bench.world.world import _days, _first_order, closest_first_order_tau


def _scene(seed: int, hours: float = 12.0):  # type: ignore[no-untyped-def]
    rig, wrig = case_rigs(str(thermrs.default_rig_path()))
    return draw_scene(wrig, Campaign(hours=hours), "white", seed, tolerances=rig.tolerances)


def test_a_rival_family_that_holds_the_truth_is_not_rejected_beyond_the_level() -> None:
    scene = _scene(31)
    truth = Truth("joint_offset", 40.0, {"joint": "joint_a3", "temperature": "link2", "sign": 1.0})
    got = strict_power_bound(scene, (truth,), rivals=("joint_offset",))
    # Its member at this joint and link spans the truth up to the kinematics' curvature.
    assert got["power_bound"] < 0.06, got
    far = strict_power_bound(scene, (truth,), rivals=("sensor_drift", "thermal_lag"))
    assert far["power_bound"] > 0.999, far


def test_the_bound_is_the_power_of_the_most_powerful_test_with_the_worlds_noise() -> None:
    """Draw the world's white visit errors on the truth's noise-free runs, test the closest
    member of the rival family (its mean known) against the truth with the likelihood ratio
    at 5 %, and count rejections: they match Φ(√λ − z₀.₉₅)."""
    scene = _scene(32)
    truth = Truth("joint_offset", 2.7, {"joint": "joint_a2", "temperature": "link3", "sign": 1.0})
    got = strict_power_bound(scene, (truth,), rivals=("unmodelled_length",))
    lam = got["lambda"]["unmodelled_length"]
    assert 0.5 < lam < 30, lam  # a case whose power is neither 0 nor 1
    # The closest member's mean, by the same least squares done here on the world's runs.
    base, series, _ = stack(render(scene, noise=False))
    d = stack(render(scene, (truth,), noise=False))[0] - base
    hi = stack(render(scene, noise=False, alpha_per_k=scene.alpha_per_k * 1.001))[0]
    fixed = [(hi - base), *(series == s for s in np.unique(series))]
    best = None
    for member in rival_members(scene, "unmodelled_length"):
        cols = [stack(render(scene, (t,), noise=False))[0] - base for t in member]
        x = np.column_stack([*fixed, *cols]).astype(float)
        m = x @ np.linalg.lstsq(x, d, rcond=None)[0]
        if best is None or np.sum((d - m) ** 2) < np.sum((d - best) ** 2):
            best = m
    assert best is not None
    sigma = scene.campaign.sigma_um
    diff = d - best
    rng = np.random.default_rng(5)
    n = 4000
    stat = (rng.normal(0, sigma, (n, d.size)) + diff) @ diff / (sigma * np.linalg.norm(diff))
    power = np.mean(stat > norm.ppf(0.95))
    expected = norm.cdf(np.linalg.norm(diff) / sigma - norm.ppf(0.95))
    assert abs(power - expected) < 4 * np.sqrt(expected * (1 - expected) / n) + 0.01
    # The world's α column here is the true rig's, the bound's the nominal's: their λ agree
    # to the few per cent the two geometries differ by.
    assert abs(np.sum(diff**2) / sigma**2 / lam - 1) < 0.1


def test_the_closest_first_order_lag_is_closer_than_the_weighted_mean() -> None:
    """A two-time-constant lag: the first-order lag the bench scores τ against lies between
    its time constants and fits the world's structures (the weight free) at least as well as
    the weighted mean time constant; a one-time-constant lag gives back its own."""
    scene = _scene(33, hours=15.0)
    one = Truth("thermal_lag", 45.0, {"ratio": 1.0})
    assert closest_first_order_tau(scene, one) == 45.0
    two = Truth("thermal_lag", 45.0, {"ratio": 4.0})
    tau = closest_first_order_tau(scene, two)
    assert 45.0 < tau < 180.0
    days = _days(scene, (two,))
    y = np.concatenate([dd.structure[k] - v for dd in days for k, v in dd.surface.items()])

    def sse(t_min: float) -> float:
        x = np.concatenate(
            [_first_order(dd.t_s, v, t_min * 60) - v for dd in days for v in dd.surface.values()]
        )
        return float(np.sum((y - (x @ y) / (x @ x) * x) ** 2))

    mean = sum(t * w for t, w in two.lags())
    assert sse(tau) <= sse(mean)
    assert sse(tau) <= min(sse(tau * 0.97), sse(tau * 1.03))


@pytest.mark.slow
def test_the_guarded_bound_is_the_level_for_no_effect_and_one_for_a_large_one() -> None:
    """Against a null whose rig errs by 3× its statement: an effect of nearly no size cannot
    be detected more often than the level (the two hypotheses then differ only in the rig's
    errors, larger under the null), and one far above the noise always is."""
    rig, _ = case_rigs(str(thermrs.default_rig_path()))
    scene = _scene(34, hours=4.0)
    tiny = Truth(
        "sensor_drift", 1e-6, {"camera": "A", "dir": np.array([1.0, 0.0]), "tau_min": 30.0}
    )
    got = guarded_power_bound(
        scene, (tiny,), tolerances=rig.tolerances, scale=3.0, draws=80, sims=8000, seed=1
    )
    assert got["power_bound"] <= 0.05 + 4 * 0.0025, got
    large = Truth(
        "sensor_drift", 30.0, {"camera": "A", "dir": np.array([1.0, 0.0]), "tau_min": 30.0}
    )
    got = guarded_power_bound(
        scene, (large,), tolerances=rig.tolerances, scale=3.0, draws=80, sims=8000, seed=1
    )
    assert got["power_bound"] > 0.999, got


def test_the_redrawn_rig_is_the_worlds_distribution() -> None:
    """The rig drawn again for the guarded bound errs as :func:`draw_scene`'s does: a DH
    length's error has the stated standard deviation times the scale."""
    from thermrs.bench.world.world import with_nuisances_redrawn

    rig, _ = case_rigs(str(thermrs.default_rig_path()))
    scene = _scene(35)
    rng = np.random.default_rng(3)
    i = int(np.flatnonzero(scene.nominal.a_mm != 0)[0])
    err = [
        with_nuisances_redrawn(scene, rig.tolerances, 2.0, rng).true.a_mm[i] - scene.nominal.a_mm[i]
        for _ in range(400)
    ]
    sd = float(np.std(err))
    assert abs(sd / (2.0 * rig.tolerances["length_mm"]) - 1) < 0.15, sd
    redrawn = with_nuisances_redrawn(scene, rig.tolerances, 2.0, rng)
    assert redrawn.days == scene.days and redrawn.links == scene.links
