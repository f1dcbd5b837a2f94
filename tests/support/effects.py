"""The SPEC §6 effects one at a time, simulated, and the residual each implies (shared by
``tests/model/test_effect_residuals.py`` and ``benchmarks/experiments/effect_residuals.py``).

"Implied" is computed independently of the simulator's output: the spot each visit should show,
from the effect's parameters through :class:`thermrs.ForwardModel` (or the closed forms of the
chip effects) at the true structure temperatures, fitted with the nominal model on the true
surface temperatures, exactly as the recording is.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import polars as pl
import thermrs
from thermrs import ForwardModel
from thermrs.fit import interpolate, run_table
from thermrs.simulate import simulate

__all__ = ["EFFECTS", "SCENARIO", "T0_NS", "implied", "run"]

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
[output]
compression = "lz4"
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
