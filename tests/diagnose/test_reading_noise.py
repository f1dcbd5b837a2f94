"""The thermal camera's reading noise: read from the readings, told apart from the chips' and
poses' repeatability in the floor, and never blamed on the robot.

The worlds are the independent bench world's (:mod:`thermrs.bench.world`: its own kinematics,
thermal network and instruments), effect-free, with 2 µm of visit repeatability at the chips
and each link's reading scattered by the world's own 0.03 K; the tests add white noise of a
known size to every link's reading (a noisy thermography: reflections, a ROI on an edge)."""

from __future__ import annotations

import numpy as np
import polars as pl
import pytest
import thermrs
from thermrs.bench.world.cases import case_rigs
from thermrs.bench.world.world import Campaign, draw_scene, render
from thermrs.compensate import compensation_law, diagnosed_model
from thermrs.diagnose import diagnose
from thermrs.effects import is_instrument

#: The world's own reading noise per link (K; :mod:`thermrs.bench.world.world`).
WORLD_K = 0.03


def _noisy_world(seed: int, extra_k: float) -> tuple[list[pl.DataFrame], float, list[str]]:
    rig, wrig = case_rigs(str(thermrs.default_rig_path()))
    scene = draw_scene(wrig, Campaign(hours=15.0), "white", seed, tolerances=rig.tolerances)
    tables = render(scene, ())
    rng = np.random.default_rng(seed)
    links = list(scene.ir_gain)
    tables = [
        t.with_columns(
            **{f"{k}_c": pl.col(f"{k}_c") + rng.normal(0.0, extra_k, t.height) for k in links}
        )
        for t in tables
    ]
    return tables, scene.campaign.sigma_um, links


@pytest.mark.parametrize("extra_k", [0.1, 0.3])
def test_each_rois_reading_noise_is_read_from_its_readings(extra_k: float) -> None:
    tables, _, links = _noisy_world(5301, extra_k)
    doc = diagnose(tables[:1], tables[1:], thermrs.load_rig(), seed=5301, bootstrap=0).to_json()
    got = doc["noise_floor"]["thermometers"]["reading_noise_k"]
    truth = float(np.hypot(extra_k, WORLD_K))
    assert set(got) == set(links)
    for k in links:
        assert abs(got[k] / truth - 1.0) < 0.1, (k, got[k], truth)


def test_a_noisy_thermography_is_the_instruments_and_the_chips_floor_is_the_worlds() -> None:
    # 0.3 K of scatter on every link's reading, ten times the world's: the nominal model's
    # held-out residual is 3.3 µm against 2 µm of visit repeatability at the chips. Smoothing
    # the readings more (symmetric: no phase) explains it; a lag of the structure, which the
    # smoothing a lag does also de-noises, was named here before the thermal camera could be.
    rig = thermrs.load_rig()
    tables, sigma, _ = _noisy_world(5102, 0.3)
    doc = diagnose(tables[:1], tables[1:], rig, seed=5102, bootstrap=0).to_json()
    v = doc["verdict"]
    assert v["effects"] == ["ir_noise"], doc["summary"]
    assert all(is_instrument(e) for e in v["effects"])
    assert v["instruments"] == ["ir_noise"]
    assert "check the thermal camera's readings" in v["reason"], v["reason"]
    th = doc["noise_floor"]["thermometers"]
    lo, hi = th["chips_ci95"]
    assert lo <= sigma <= hi
    assert th["thermometers_um"] > 0.1
    # The law says to smooth the readings as the diagnosis did.
    law = compensation_law(rig, diagnosed_model(doc, rig))
    terms = set(law.table["term"].to_list())
    assert any(t.startswith("smooth every T") for t in terms), terms
