"""Issue #4's round trip: the nominal model fitted to a simulated recording leaves residuals at
the noise level with no effect, and each SPEC §6 effect alone leaves the residual its
parameters imply.

"Implied" is computed here, independently of the simulator's output: the spot each visit should
show, from the effect's parameters through :class:`thermrs.ForwardModel` (or the closed forms of
the chip effects) at the true structure temperatures, is fitted with the nominal model on the
true surface temperatures, exactly as the recording is; its residual RMS is what the effect
implies. The recording's residual adds the measurement noise in quadrature.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import polars as pl
import pytest
import thermrs
from thermrs import ForwardModel
from thermrs.fit import fit_alpha, interpolate, run_table
from thermrs.predict import noise_um
from thermrs.simulate import simulate

T0_NS = 1_750_000_000 * 10**9  # the simulator's clock at the first run's start

SCENARIO = """format = "thermrs-scenario/1"
seed = 77
[[run]]
name = "run"
speed_pct = 75
duration_min = 180
cycle_s = 120
start = "ambient"
[ambient]
start_c = 23.38
drift_c_per_h = 0.6
[camera]
frames_per_visit = 4
[motion]
repeatability_urad = 0.0
{effect}
"""

#: name → (scenario [[effect]] text, ForwardModel keywords, chip-effect function or None)
EFFECTS: dict[str, tuple[str, dict[str, Any]]] = {
    "alpha_per_link": (
        "alpha_per_k = { link2 = 15e-6, link3 = 32e-6 }",
        {"alpha_by_temperature": {"link2": 15e-6, "link3": 32e-6}},
    ),
    "thermal_lag": ("tau_min = 30", {}),
    "unmodelled_length": (
        'length = "a3"\ntemperature = "link3"',
        {"extra_lengths": {"a3": "link3"}},
    ),
    "fixture_drift": ('camera = "A"\num_per_k = [3.0, -2.0]', {}),
    "laser_tilt": ("tilt_deg = 1.0", {"laser_tilt_deg": 1.0}),
    "joint_offset": (
        'joint = "joint_a2"\ntemperature = "link2"\nurad_per_k = 20.0',
        {"joint_offsets": [("joint_a2", "link2", 20.0)]},
    ),
    "nonlinear_alpha": ("kappa_per_k = 0.08", {"kappa_per_k": 0.08}),
    "sensor_drift": ('camera = "B"\ntau_min = 40\num = [10.0, -8.0]', {}),
}


def run(tmp: Path, rig: thermrs.Rig, name: str) -> tuple[pl.DataFrame, pl.DataFrame]:
    """Simulate one effect (or none): its run table and the true samples."""
    effect = "" if name == "none" else f'[[effect]]\nname = "{name}"\n{EFFECTS[name][0]}\n'
    sc = tmp / f"{name}.toml"
    sc.write_text(SCENARIO.format(effect=effect))
    sim = simulate(rig, sc, tmp / f"{name}.mcap")
    return run_table(thermrs.extract(sim.recording, rig), rig), sim.samples.sort("t_ns")


def implied(
    table: pl.DataFrame, samples: pl.DataFrame, rig: thermrs.Rig, name: str
) -> pl.DataFrame:
    """The run table as the effect alone would make it: noise-free spots from the effect's
    parameters at the true structure temperatures; true surface temperatures as the readings."""
    st = samples["t_ns"].to_numpy().astype(float)
    t = table["t_ns"].to_numpy().astype(float)

    def at(col: str) -> np.ndarray:
        return interpolate(t, st, samples[col].to_numpy())

    kw = EFFECTS[name][1] if name in EFFECTS else {}
    model = ForwardModel(rig, **kw)
    structure = {n: at(f"{n}_structure_c") for n in model.temperature_names}
    u = np.empty(table.height)
    v = np.empty(table.height)
    for cam in rig.cameras:
        idx = np.flatnonzero((table["camera"] == cam.name).to_numpy())
        s = model.spots(
            cam.name,
            rig.camera_pose(cam.name).joints_rad,
            temperatures={n: x[idx] for n, x in structure.items()},
        )
        u[idx], v[idx] = s.u_um, s.v_um
        if name == "fixture_drift" and cam.name == "A":
            ambient = 23.38 + 0.6 * (t[idx] - T0_NS) / 3.6e12
            u[idx] += 3.0 * (ambient - rig.reference_c)
            v[idx] += -2.0 * (ambient - rig.reference_c)
        if name == "sensor_drift" and cam.name == "B":
            f = 1 - np.exp(-(t[idx] - T0_NS) / 1e9 / (40 * 60))
            u[idx] += 10.0 * f
            v[idx] += -8.0 * f
    return table.with_columns(
        u_um=pl.Series(u),
        v_um=pl.Series(v),
        **{f"{n}_c": pl.Series(at(f"{n}_surface_c")) for n in ("link2", "link3", "base")},
    )


@pytest.fixture(scope="module")
def baseline(tmp_path_factory: pytest.TempPathFactory) -> dict[str, float]:
    rig = thermrs.load_rig()
    table, samples = run(tmp_path_factory.mktemp("none"), rig, "none")
    f = fit_alpha([table], rig)
    noise = math.sqrt(
        np.mean(
            [
                noise_um(table.filter(pl.col("camera") == c)[f"{a}_um"].to_numpy()) ** 2
                for c in ("A", "B")
                for a in ("u", "v")
            ]
        )
    )
    ideal = fit_alpha([implied(table, samples, rig, "none")], rig)
    return {"rms": f.rms_um, "noise": noise, "alpha": f.alpha_per_k, "ideal": ideal.rms_um}


def test_no_effect_leaves_residuals_at_the_noise_level(baseline: dict[str, float]) -> None:
    """The nominal model on a `none` recording: residual RMS within 2× the measurement's own
    visit-to-visit noise, α within 1 % of the simulator's, and the noise-free version exact.

    (Issue #9: the noise is 0.11–0.15 µm per axis, as the within-visit centroid scatter
    says independently (0.10–0.12 µm); the von Neumann estimator used before read 0.29–0.35
    µm because the drift's own step from visit to visit was in it. The residual, 0.20 µm,
    also carries the ROI readings' error.)"""
    assert baseline["ideal"] < 1e-6
    assert baseline["rms"] < 2.0 * baseline["noise"], baseline
    assert baseline["noise"] < 0.5, baseline
    assert baseline["alpha"] == pytest.approx(23.2e-6, rel=0.01)


@pytest.mark.parametrize("name", sorted(EFFECTS))
def test_each_effect_leaves_the_residual_its_parameters_imply(
    name: str, baseline: dict[str, float], tmp_path: Path, paper_rig: thermrs.Rig
) -> None:
    table, samples = run(tmp_path, paper_rig, name)
    measured = fit_alpha([table], paper_rig)
    want = fit_alpha([implied(table, samples, paper_rig, name)], paper_rig)
    if name == "laser_tilt":
        # A tilted laser mostly shifts the spot by a constant, which the per-camera offsets
        # absorb; what the expansion adds is nanometres (1° at 106 mm: 0.01 µm RMS). Implied
        # tiny, measured at the noise floor.
        assert want.rms_um < 0.05, want
        assert measured.rms_um < 1.1 * baseline["rms"] + want.rms_um
        return
    # Big enough to see: well above the noise floor.
    assert want.rms_um > 3 * baseline["rms"], (name, want.rms_um, baseline)
    excess = math.sqrt(max(measured.rms_um**2 - baseline["rms"] ** 2, 0.0))
    assert excess == pytest.approx(want.rms_um, rel=0.15), (name, excess, want.rms_um)
    # And the α the nominal model absorbs is the one the effect implies.
    assert measured.alpha_per_k == pytest.approx(want.alpha_per_k, rel=0.03, abs=0.3e-6), name
