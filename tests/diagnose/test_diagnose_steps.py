"""Each step of the diagnoser on its own, against a truth the step did not make: known noise
processes (floor), closed forms (smoothing, block length), a Monte Carlo spread (cycle
bootstrap), the library without the excluded effect, the README's own lag example."""

from __future__ import annotations

import numpy as np
import polars as pl
import pytest
import thermrs
from thermrs.bench import make_runs
from thermrs.diagnose import diagnose, noise_floor_um
from thermrs.diagnose.floor import series_noise
from thermrs.diagnose.input_checks import loess2, smooth_temperatures
from thermrs.diagnose.resample import block_length
from thermrs.diagnose.verdict import english_list


@pytest.fixture(scope="module")
def rig() -> thermrs.Rig:
    return thermrs.load_rig()


def _ar1(n: int, phi: float, sd: float, rng: np.random.Generator) -> np.ndarray:
    out = np.empty(n)
    out[0] = rng.normal(0, sd)
    for i in range(1, n):
        out[i] = phi * out[i - 1] + rng.normal(0, sd * np.sqrt(1 - phi * phi))
    return out


@pytest.mark.parametrize(("white", "corr", "tau_min"), [(2.0, 0.0, 0.0), (1.5, 1.5, 20.0)])
def test_the_floor_finds_known_noise_and_leaves_a_slow_gap_out(
    white: float, corr: float, tau_min: float
) -> None:
    # 15 h at 10-minute cycles: white noise plus a pose error correlated over tau_min, with a
    # slow thermal-lag-like gap (hours) on top; the floor must be the noise, not the gap.
    rng = np.random.default_rng(5)
    t = np.arange(0, 15 * 3600, 600.0)
    est = []
    for _ in range(40):
        noise = rng.normal(0, white, len(t))
        if corr:
            noise += _ar1(len(t), np.exp(-600 / (tau_min * 60)), corr, rng)
        gap = 6.0 * np.exp(-t / (200 * 60)) * (1 - np.exp(-t / (40 * 60)))
        w, a, _ = series_noise(noise + gap, t, tau_c_max_s=30 * 60)  # type: ignore[misc]
        est.append(np.hypot(w, a))
    truth = np.hypot(white, corr)
    assert np.median(est) == pytest.approx(truth, rel=0.12)
    # The old variogram (correlation up to ρ 0.95 a visit) read the gap as noise: the floor
    # must stay well below the residual's rms.
    assert np.median(est) < 0.9 * np.sqrt(truth**2 + np.mean(gap**2))


def test_smoothing_keeps_a_heating_curve_and_removes_reading_noise() -> None:
    rng = np.random.default_rng(1)
    t = np.arange(0, 15 * 3600, 60.0)
    curve = 30.0 - 7.0 * np.exp(-t / (300 * 60))
    got = loess2(t, curve + rng.normal(0, 0.03, len(t)), 30 * 60)
    # a local quadratic is exact to second order: the bias is far below the reading noise
    assert np.max(np.abs(loess2(t, curve, 30 * 60) - curve)) < 2e-3
    assert np.std(got - curve) < 0.35 * 0.03
    table = pl.DataFrame(
        {
            "run": ["r"] * len(t),
            "camera": ["A"] * len(t),
            "t_ns": (t * 1e9).astype(np.int64),
            "link2_c": curve,
        }
    )
    out = smooth_temperatures([table], 30 * 60)[0]
    assert out.columns == table.columns and out.height == table.height


@pytest.mark.parametrize("phi", [0.0, 0.5, 0.8])
def test_block_length_is_the_ar1_variance_inflation(phi: float) -> None:
    rng = np.random.default_rng(2)
    x = _ar1(4000, phi, 1.0, rng)
    assert block_length(x) == pytest.approx((1 + phi) / (1 - phi), abs=1.5)


def test_english_lists() -> None:
    assert english_list(["a"]) == "a"
    assert english_list(["a", "b"], conj="or") == "a or b"
    assert english_list(["a", "b", "c"], conj="or") == "a, b or c"


@pytest.mark.slow
@pytest.mark.floors
def test_an_excluded_effect_is_gone_from_the_library(rig: thermrs.Rig) -> None:
    runs = make_runs(rig, thermrs.effects.ThermalLag(tau_min=70.0), seed=7, hours=6.0)
    d = diagnose(runs[:1], runs[1:], rig, bootstrap=0, exclude=["thermal_lag"], null_draws=49)
    assert "thermal_lag" not in d.library
    assert all(r["effect"] != "thermal_lag" for r in d.ranking)
    assert "thermal_lag" not in d.verdict["confounded_with"]
    assert d.status != "none"


def test_delta_aicc_penalises_a_useless_column(rig: thermrs.Rig) -> None:
    # On effect-free runs a candidate's ΔAICc may favour it only by what it gains: the
    # penalty of its extra parameters is positive (the old formula subtracted the held-out
    # offsets and favoured every candidate by twice their number).
    runs = make_runs(rig, None, seed=8, hours=6.0, perturb=False)
    d = diagnose(runs[:1], runs[1:], rig, bootstrap=0, null_draws=49)
    for r in d.ranking:
        if r["evidence"]["gap_closed_raw"] is not None and r["shrink"] < 0.005:
            assert r["evidence"]["delta_aicc"] > -10.0, r["family"]


@pytest.mark.slow
@pytest.mark.floors
def test_no_effect_gives_none_in_most_seeds(rig: thermrs.Rig) -> None:
    # The null world's tests at 5 %: a run without any gap is called otherwise rarely.
    wrong = 0
    for seed in range(5):
        runs = make_runs(rig, None, seed=100 + seed, hours=6.0, cycle_s=300.0, perturb=False)
        d = diagnose(runs[:1], runs[1:], rig, bootstrap=0, null_draws=99, seed=seed)
        wrong += d.status != "none"
    assert wrong <= 1


def test_two_effects_at_once_are_both_named_or_the_rest_called_unexplained(
    rig: thermrs.Rig,
) -> None:
    # An independent world (its own kinematics and physics) with a lag and a fixture drift at
    # once: never one effect `identified` alone while the other leaves a gap.
    from thermrs.bench.world.world import Campaign

    from tests.support.pairs import run_pair

    row = run_pair(
        ("thermal_lag", "fixture_drift"),
        rig_path=str(rig.source),
        snr=3.0,
        lowest_snr=1.0,
        seed=4242,
        campaign=Campaign(hours=12.0, cycle_s=600.0, sigma_um=2.0),
    )
    named = set(row["named"])
    assert row["status"] != "none"
    if row["status"] == "identified":
        assert {"thermal_lag", "fixture_drift"} <= named, row


@pytest.mark.slow
@pytest.mark.floors
def test_a_rig_file_path_is_a_rig(rig: thermrs.Rig) -> None:
    # As every other function takes it: the path of the rig file, str or Path.
    runs = make_runs(rig, None, seed=21, hours=4.0)
    by_path = diagnose(runs[:1], runs[1:], str(rig.source), bootstrap=0, null_draws=19)
    by_rig = diagnose(runs[:1], runs[1:], rig, bootstrap=0, null_draws=19)
    assert by_path.baseline["holdout_rms_um"] == by_rig.baseline["holdout_rms_um"]
    with pytest.raises(thermrs.InputError, match=r"no-such-rig\.toml"):
        diagnose(runs[:1], runs[1:], "no-such-rig.toml", bootstrap=0)
    # The floor alone (what the design's noise calibration asks) is the diagnosis's floor,
    # and refuses what the diagnosis refuses.
    assert noise_floor_um(runs[:1], runs[1:], str(rig.source)) == by_rig.noise_floor_um
    with pytest.raises(thermrs.InputError):
        noise_floor_um(runs[:1], runs[:1], rig)


def test_holm_step_down() -> None:
    from thermrs.diagnose.selection import holm_kept

    # level 0.05, three p-values: 0.01 < 0.05/3 rejected; 0.03 ≥ 0.05/2 kept, and so is 0.04.
    assert holm_kept({"a": 0.01, "b": 0.04, "c": 0.03}, 0.05) == ["c", "b"]
    # 0.01 < 0.05/3, 0.02 < 0.05/2, 0.04 < 0.05/1: all rejected (Bonferroni would keep 0.02).
    assert holm_kept({"a": 0.01, "b": 0.02, "c": 0.04}, 0.05) == []
    assert holm_kept({}, 0.05) == []


def test_an_interval_takes_in_how_far_its_value_moves_over_a_time_constant_in_quadrature() -> None:
    """Closed forms: a half-width h and a move m to one side make √(h² + m²) on that side and
    leave the other; vectors per entry, dicts per key, a parameter without a move unchanged."""
    from thermrs.diagnose.final_model import _widened

    got = _widened([[-1.0, 1.0], [0.0, 2.0]], [0.0, 1.0], [[-2.0, 1.5], [0.5, 1.0]])
    assert got[0] == pytest.approx([-np.sqrt(5.0), np.sqrt(1.25)])
    assert got[1] == pytest.approx([0.0, 1.0 + np.sqrt(1.25)])
    got = _widened(
        {"alpha_per_k": {"link2": [1.0, 3.0]}, "gain": [0.1, 0.3]},
        {"alpha_per_k": {"link2": 2.0}, "gain": 0.2},
        [{"alpha_per_k": {"link2": 4.0}}],
    )
    assert got["alpha_per_k"]["link2"] == pytest.approx([1.0, 2.0 + np.sqrt(5.0)])
    assert got["gain"] == [0.1, 0.3]
