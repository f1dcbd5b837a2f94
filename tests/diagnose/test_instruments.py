"""A miscalibrated thermal camera is named as the instrument, never blamed on the robot.

The runs come from the independent bench world (:mod:`thermrs.bench.world`: its own
kinematics, thermal network and IR camera model), with no effect of the robot and one ROI's
reading of its rise above the room far off (an emissivity set wrong for that surface). The
truth is the world's: that ROI's gain against the others' (their common gain is α's, which
the fit absorbs).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import thermrs
from thermrs.bench.world.cases import case_rigs
from thermrs.bench.world.world import Campaign, draw_scene, render
from thermrs.diagnose import diagnose
from thermrs.effects import (
    INSTRUMENT_EFFECTS,
    IrClock,
    IrDrift,
    IrGain,
    effect_classes,
    from_dict,
)
from thermrs.instruments import clock_shifted


@pytest.mark.slow
@pytest.mark.parametrize(
    ("world", "seed", "roi", "factor"),
    [("white", 5401, "link3", 0.75), ("ar1", 5402, "link2", 1.25)],
)
def test_a_wrong_emissivity_is_named_as_the_instrument(
    world: str, seed: int, roi: str, factor: float
) -> None:
    rig, wrig = case_rigs(str(thermrs.default_rig_path()))
    scene = draw_scene(wrig, Campaign(), world, seed, tolerances=rig.tolerances)
    gains = dict(scene.ir_gain)
    gains[roi] *= factor
    scene = dataclasses.replace(scene, ir_gain=gains)
    tables = render(scene, ())
    d = diagnose(tables[:1], tables[1:], rig, bootstrap=0, seed=seed).to_json()
    v = d["verdict"]
    assert v["status"] == "identified", v["reason"]
    assert v["effect"] == "ir_gain" and v["params"]["roi"] == roi
    assert v["effects"] == ["ir_gain"] and v["instruments"] == ["ir_gain"]
    others = np.mean([g for r, g in gains.items() if r != roi])
    truth = gains[roi] / others - 1.0
    lo, hi = v["params_ci95"]["gain"]
    assert lo <= truth <= hi, (truth, lo, hi)
    assert f"check the emissivity of {roi}" in v["reason"]
    assert "not the robot's" in v["reason"]


def test_instrument_effects_correct_the_readings_as_stated() -> None:
    # Closed forms of each correction on a few readings: a gain on the rise above the room,
    # a drift since the run's start, a clock shift within each run.
    class Visits:
        run = np.array(["a", "a", "a", "b", "b"])
        t_s = np.array([0.0, 600.0, 1200.0, 5000.0, 5600.0])
        t_since_start = np.array([0.0, 600.0, 1200.0, 0.0, 600.0])

    temps = {"link3": np.array([20.0, 23.0, 26.0, 30.0, 31.0]), "ambient": np.full(5, 20.0)}
    got = IrGain(roi="link3", gain=0.5).corrected(temps, Visits(), 20.0)
    np.testing.assert_allclose(got["link3"], [20.0, 22.0, 24.0, 26.6666666667, 27.3333333333])
    got = IrDrift(roi="link3", k_per_h=0.6).corrected(temps, Visits(), 20.0)
    np.testing.assert_allclose(got["link3"], temps["link3"] - [0.0, 0.1, 0.2, 0.0, 0.1])
    got = IrClock(s=300.0).corrected(temps, Visits(), 20.0)
    np.testing.assert_allclose(got["link3"], [21.5, 24.5, 26.0, 30.5, 31.0])
    np.testing.assert_array_equal(got["ambient"], temps["ambient"])


def test_a_clock_shift_moves_the_heating_curve_not_the_reading_noise() -> None:
    # Readings every 5 min (two cameras' visits interleaved) on a quadratic heating curve,
    # with 0.03 K of independent reading noise. Read s later, each reading must move by the
    # curve's own change over s, 2c·t·s + c·s² (closed form; the curve is read between two
    # visits by straight lines, off by at most c·s·(300 − s)), and keep its noise: averaging
    # neighbours' noise would take noise off the model's prediction and read as a clock
    # error in a run that has none.
    rng = np.random.default_rng(7)
    t = np.arange(180) * 300.0
    c = 2e-9
    curve = 20.0 + 1e-4 * t + c * t**2
    noise = rng.normal(0.0, 0.03, t.size)
    s = 150.0
    inside = t + s <= t[-1]
    exact = clock_shifted(t, curve, s)
    np.testing.assert_allclose(
        exact[inside] - curve[inside],
        1e-4 * s + 2 * c * t[inside] * s + c * s**2,
        atol=c * s * (300.0 - s) * (1 + 1e-6),
    )
    moved = clock_shifted(t, curve + noise, s) - (curve + noise)
    want = 1e-4 * s + 2 * c * t * s + c * s**2
    assert np.std(moved[inside] - want[inside]) < 0.003
    # What interpolating between the readings does instead: half of each neighbour's noise.
    interp = np.interp(t + s, t, curve + noise) - (curve + noise)
    assert np.std(interp[inside] - want[inside]) > 0.015


def test_instrument_effects_are_checked_against_the_rig_and_their_bounds() -> None:
    rig = thermrs.load_rig()
    assert set(INSTRUMENT_EFFECTS) <= set(effect_classes())
    assert from_dict({"name": "ir_clock", "s": 12.0}, rig=rig) == IrClock(s=12.0)
    with pytest.raises(thermrs.InputError, match="no ROI 'elbow'"):
        from_dict({"name": "ir_gain", "roi": "elbow", "gain": 0.1}, rig=rig)
    with pytest.raises(thermrs.InputError, match="beyond"):
        from_dict({"name": "ir_drift", "roi": "link3", "k_per_h": 9.0}, rig=rig)
