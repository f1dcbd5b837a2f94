"""The simulator: round trip through extraction against its own truth, reproducibility, the
paper runs' temperatures, and its error contract."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import polars as pl
import pytest
import thermrs
from thermrs.fit import interpolate
from thermrs.simulate import simulate

#: Simulations and campaigns of minutes: skipped by `pytest -m "not slow"`.
pytestmark = pytest.mark.slow

REPO = Path(__file__).resolve().parents[2]
SHORT = """
format = "thermrs-scenario/1"
seed = 7
[[run]]
name = "warm"
speed_pct = 75
duration_min = 60
cycle_s = 300
start = "ambient"
[[run]]
name = "cool"
speed_pct = 10
duration_min = 30
cycle_s = 300
[camera]
frames_per_visit = 2
[output]
compression = "{compression}"
"""


def short(tmp_path: Path, compression: str = "zstd", extra: str = "") -> Path:
    p = tmp_path / "short.toml"
    p.write_text(SHORT.format(compression=compression) + extra)
    return p


@pytest.mark.parametrize("compression", ["zstd", "none"])
def test_extraction_recovers_the_simulated_truth(
    tmp_path: Path, paper_rig: thermrs.Rig, compression: str
) -> None:
    sim = simulate(paper_rig, short(tmp_path, compression), tmp_path / "sim.mcap")
    assert sim.frames.height == (12 + 6) * 2 * 2  # cycles × cameras × frames per visit
    ex = thermrs.extract(sim.recording, paper_rig)
    assert not ex.report.data_loss and ex.report.skipped == {}
    j = ex.frames.join(sim.frames, on=["camera", "t_ns"], suffix="_true")
    assert j.height == sim.frames.height
    assert (j["status"] == "ok").all()
    err = np.concatenate(
        [(j["x_px"] - j["x_px_true"]).to_numpy(), (j["y_px"] - j["y_px_true"]).to_numpy()]
    )
    # Extraction accuracy on the simulator's spot (σ 4 px, 8-bit): CRB 0.027 px.
    assert np.sqrt(np.mean(err**2)) < 1.3 * 0.0273 and abs(err.mean()) < 0.01
    # One visit per camera and cycle, two frames each.
    assert ex.visits.height == 36 and (ex.visits["n_ok"] == 2).all()
    # IR ROI maxima follow the true surface temperature (max of noisy pixels: a small bias up).
    t = ex.temperatures.filter(pl.col("name") == "link2").sort("t_ns")
    assert t.height == sim.samples.height
    d = t["temperature_c"].to_numpy() - sim.samples.sort("t_ns")["link2_surface_c"].to_numpy()
    assert np.all(d > -0.02) and np.all(d < 0.25), d
    # The first run warms link 2 first order from ambient: 23.38 + ΔT_ss(75 %)·(1 − e^{−t/τ})
    # with the calibration's ΔT_ss = 5.467 K and τ = 391.6 min (heat::kr15_paper_nodes).
    # Samples are taken by the thermal frame, two thirds into each 5-minute cycle.
    s = sim.samples.filter(run="warm")["link2_surface_c"].to_numpy()
    t_min = np.arange(len(s)) * 5.0 + 200.0 / 60.0
    assert s == pytest.approx(23.38 + 5.467 * (1 - np.exp(-t_min / 391.6)), abs=0.005)


def test_same_seed_same_bytes(tmp_path: Path, paper_rig: thermrs.Rig) -> None:
    sc = short(tmp_path)
    a = simulate(paper_rig, sc, tmp_path / "a.mcap").recording.read_bytes()
    b = simulate(paper_rig, sc, tmp_path / "b.mcap").recording.read_bytes()
    c = simulate(paper_rig, sc, tmp_path / "c.mcap", seed=8).recording.read_bytes()
    assert a == b
    assert a != c


def test_effect_moves_the_truth_by_its_parameters(tmp_path: Path, paper_rig: thermrs.Rig) -> None:
    """sensor_drift on camera B: B's true spot moves by um·(1 − e^{-t/τ}); A's does not."""
    base = simulate(paper_rig, short(tmp_path), tmp_path / "n.mcap").frames
    eff = short(
        tmp_path,
        extra='[[effect]]\nname = "sensor_drift"\ncamera = "B"\ntau_min = 20\num = [5.0, -3.0]\n',
    )
    drift = simulate(paper_rig, eff, tmp_path / "d.mcap").frames
    j = base.join(drift, on=["camera", "t_ns"], suffix="_e")
    a = j.filter(camera="A")
    assert np.allclose(a["x_px"], a["x_px_e"]) and np.allclose(a["y_px"], a["y_px_e"])
    b = j.filter(camera="B", run="warm")
    # Since the run began: the first run starts at the simulator's epoch (simulate::T0_NS);
    # the spot is taken at mid-exposure (default 10 ms).
    t = (b["t_ns"].to_numpy() - 1_750_000_000 * 10**9) / 1e9 + 0.005
    want_u = 5.0 * (1 - np.exp(-t / (20 * 60)))
    got_u = (b["x_px_e"] - b["x_px"]).to_numpy() * 8.6
    assert np.allclose(got_u, want_u, atol=0.05)


def test_paper_runs_land_on_table4(tmp_path: Path, paper_rig: thermrs.Rig) -> None:
    """fixtures/scenarios/paper-runs.toml (coarsened to 30-minute cycles to stay small):
    link 2 and link 3 start and end every run near Table 4."""
    text = (REPO / "fixtures/scenarios/paper-runs.toml").read_text()
    text = text.replace("cycle_s = 60", "cycle_s = 1800").replace(
        "frames_per_visit = 2", "frames_per_visit = 1"
    )
    p = tmp_path / "paper.toml"
    p.write_text(text)
    s = simulate(paper_rig, p, tmp_path / "paper.mcap").samples
    table4 = {  # run: (start link2, start link3, end link2, end link3)
        "run1": (23.40, 23.35, 28.10, 30.10),
        "run2": (24.40, 24.34, 28.40, 30.65),
        "run3": (28.40, 30.65, 27.20, 28.45),
    }
    # Run start times (min): run1 at 0, 10 h idle, run2, run3 straight after.
    starts = {"run1": 0.0, "run2": 1500.0, "run3": 2400.0}
    t0 = 1_750_000_000 * 10**9
    for run, (s2, s3, e2, e3) in table4.items():
        r = s.filter(run=run).sort("t_ns")
        t_min = (r["t_ns"].to_numpy() - t0) / 6e10
        at = np.array([starts[run], starts[run] + 900.0])
        # Read the run's start and end off its own samples (thermal frames come 20 min into
        # each 30-min cycle).
        link2 = interpolate(at, t_min, r["link2_surface_c"].to_numpy())
        link3 = interpolate(at, t_min, r["link3_surface_c"].to_numpy())
        assert link2 == pytest.approx([s2, e2], abs=0.1), run
        assert link3 == pytest.approx([s3, e3], abs=0.1), run


def test_bad_scenario_exits_2_naming_the_key(tmp_path: Path) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text(SHORT.format(compression="gzip"))
    p = subprocess.run(
        [
            sys.executable,
            "-m",
            "thermrs",
            "simulate",
            "--rig",
            str(thermrs.default_rig_path()),
            "--scenario",
            str(bad),
            "-o",
            str(tmp_path / "x.mcap"),
        ],
        capture_output=True,
        text=True,
    )
    assert p.returncode == 2, p.stderr
    assert "output.compression" in p.stderr and "Traceback" not in p.stderr
    assert not (tmp_path / "x.mcap").exists()
    with pytest.raises(thermrs.errors.ScenarioError, match=r"output\.compression"):
        simulate(thermrs.load_rig(), bad, tmp_path / "y.mcap")


NODES = """
[[node]]
name = "link2"
tau_min = 391.643331
rise_saturating = {{ r0_k = 0.438342, span_k = 5.030472, s0 = 0.0964029 }}
[[node]]
name = "link3"
tau_min = 308.339005
rise_saturating = {{ r0_k = 1.602697, span_k = 6.041837, s0 = 0.1241591 }}
[[node]]
name = "base"
tau_min = 600.0
rise_k = {base}
"""


def test_scenario_nodes_in_either_form(tmp_path: Path, paper_rig: thermrs.Rig) -> None:
    """Explicit nodes with the calibration's saturating rises (rounded) simulate like the
    defaults, and the truth JSON echoes each node with the one rise form it was given."""
    p = short(tmp_path, extra=NODES.format(base="[0.10, 0.85, 0.50]"))
    sim = simulate(paper_rig, p, tmp_path / "n.mcap")
    default = simulate(paper_rig, short(tmp_path), tmp_path / "d.mcap")
    for col in ("link2_surface_c", "link3_surface_c", "base_surface_c"):
        assert np.allclose(sim.samples[col], default.samples[col], atol=1e-5), col
    nodes = sim.scenario["node"]
    assert nodes[0] == {
        "name": "link2",
        "tau_min": 391.643331,
        "rise_saturating": {"r0_k": 0.438342, "span_k": 5.030472, "s0": 0.0964029},
    }
    assert nodes[2] == {"name": "base", "tau_min": 600.0, "rise_k": [0.10, 0.85, 0.50]}
    doc = json.loads((tmp_path / "n.truth.json").read_text())
    assert doc["node"] == nodes


def test_decreasing_rise_is_a_scenario_error(tmp_path: Path) -> None:
    """The old link 2 quadratic (peaks at ~55 % speed) is rejected, naming the key."""
    bad = short(tmp_path, extra=NODES.format(base="[2.5695, 12.2877, -11.2331]"))
    with pytest.raises(thermrs.errors.ScenarioError, match=r"node\[2\]\.rise_k: .*decreases"):
        simulate(thermrs.load_rig(), bad, tmp_path / "y.mcap")
    assert not (tmp_path / "y.mcap").exists()


def test_sixteen_bit_frames_and_float_thermal(tmp_path: Path, paper_rig: thermrs.Rig) -> None:
    extra = (
        "[camera]\nbits = 16\npeak_dn = 16000\nbackground_dn = 100\nread_noise_dn = 12\n"
        'dn_per_electron = 8\n[ir]\nencoding = "32FC1"\n'
    )
    text = SHORT.format(compression="lz4").replace("[camera]\nframes_per_visit = 2\n", "")
    p = tmp_path / "s16.toml"
    p.write_text(text + extra)
    sim = simulate(paper_rig, p, tmp_path / "s16.mcap")
    ex = thermrs.extract(sim.recording, paper_rig)
    j = ex.frames.join(sim.frames, on=["camera", "t_ns"], suffix="_true")
    assert j.height == sim.frames.height and (j["status"] == "ok").all()
    err = (j["x_px"] - j["x_px_true"]).to_numpy()
    assert np.sqrt(np.mean(err**2)) < 1.3 * 0.0094  # the 16-bit camera's bound
    t = ex.temperatures.filter(pl.col("name") == "link3").sort("t_ns")["temperature_c"]
    d = t.to_numpy() - sim.samples.sort("t_ns")["link3_surface_c"].to_numpy()
    assert np.all(np.abs(d) < 0.25)


def test_continuous_cameras_see_dark_frames_and_smeared_spots(
    tmp_path: Path, paper_rig: thermrs.Rig
) -> None:
    """Continuous recording: most frames dark, spot frames only while the laser is on the chip
    (the dwell, and the ends of the moves, where the spot is smeared); visits found from the
    joint states."""
    text = (
        'format = "thermrs-scenario/1"\nseed = 3\n[[run]]\nname = "r"\nspeed_pct = 10\n'
        'duration_min = 1\ncycle_s = 30\nstart = "ambient"\n'
        '[camera]\nmode = "continuous"\nframe_rate_hz = 10\nexposure_s = 0.05\n'
        "[motion]\ndwell_s = 2\n"
    )
    p = tmp_path / "cont.toml"
    p.write_text(text)
    sim = simulate(paper_rig, p, tmp_path / "cont.mcap")
    assert sim.frames.height == 2 * 2 * 300  # cycles × cameras × 30 s × 10 Hz
    lit = sim.frames.filter(pl.col("x_px").is_not_nan())
    assert 0 < lit.height < 0.15 * sim.frames.height
    ex = thermrs.extract(sim.recording, paper_rig)
    j = ex.frames.join(sim.frames, on=["camera", "t_ns"], suffix="_true")
    dark = j.filter(pl.col("x_px_true").is_nan())
    assert (dark["status"] == "no_spot").all()
    still = j.filter(pl.col("status") == "ok")
    assert still.height >= 2 * 2 * 19  # ≥ 19 still frames per 2-s dwell
    err = (still["x_px"] - still["x_px_true"]).to_numpy()
    assert np.sqrt(np.mean(err**2)) < 0.05
    # Every visit (2 cycles × 2 cameras) is found from the joint states and the frames.
    assert ex.visits.height == 4 and (ex.visits["n_ok"] >= 19).all()
    # Joint states sample the moves too, not only the poses.
    assert ex.joints.height > 2 * 30 * 2


def test_truth_holds_every_expanding_length(tmp_path: Path, paper_rig: thermrs.Rig) -> None:
    """The truth samples carry each expanding length: the rig's a2 (link 2) and d4 (link 3),
    and an unmodelled a3, each L·(1 + α·ΔT·(1 + κ·ΔT)) at its structure temperature."""
    extra = (
        '[[effect]]\nname = "unmodelled_length"\nlength = "a3"\ntemperature = "link3"\n'
        '[[effect]]\nname = "nonlinear_alpha"\nkappa_per_k = 0.01\n'
    )
    s = simulate(paper_rig, short(tmp_path, extra=extra), tmp_path / "sim.mcap").samples
    ref, alpha = paper_rig.reference_c, paper_rig.alpha_per_k
    for col, nominal, node in (("a2_mm", 650.0, "link2"), ("d4_mm", -600.0, "link3"),
                               ("a3_mm", 152.91, "link3")):  # fmt: skip
        dt = s[f"{node}_structure_c"].to_numpy() - ref
        want = nominal * (1 + alpha * dt * (1 + 0.01 * dt))
        assert np.allclose(s[col].to_numpy(), want, rtol=0, atol=1e-9), col
    assert (s["a2_mm"] > 650.0).all()  # warmer than the reference throughout


def test_start_times_date_the_recording_and_the_idle_day_between_runs(tmp_path: Path) -> None:
    """`start_time` (the scenario's, a run's): the recording's stamps start then, a run given
    its own start waits (idle, cooling) until it, and extraction and the campaign's catalog
    see those days."""
    from datetime import UTC, datetime

    rig = thermrs.load_rig()
    t0 = datetime(2026, 11, 2, 7, 30, tzinfo=UTC)
    t1 = datetime(2026, 11, 3, 7, 30, tzinfo=UTC)
    sc = tmp_path / "s.toml"
    sc.write_text(
        SHORT.format(compression="zstd")
        .replace("seed = 7", f"seed = 7\nstart_time = {t0.isoformat().replace('+00:00', 'Z')}")
        .replace('name = "cool"', f'name = "cool"\nstart_time = "{t1.isoformat()}"')
    )
    sim = simulate(rig, sc, tmp_path / "r.mcap")
    first = sim.frames.group_by("run").agg(pl.col("t_ns").min()).sort("t_ns")
    t0_ns, t1_ns = int(t0.timestamp()) * 10**9, int(t1.timestamp()) * 10**9
    warm, cool = first["t_ns"].to_list()
    # The first visit of a cycle lies within that cycle (300 s) of its start.
    assert t0_ns <= warm < t0_ns + 300 * 10**9
    assert t1_ns <= cool < t1_ns + 300 * 10**9
    # The idle day cooled the robot: the second run starts near ambient, not warm.
    temps = sim.samples.sort("t_ns")
    amb = temps["ambient_c"]
    assert (
        abs(float(temps.filter(pl.col("run") == "cool")["link3_structure_c"][0]) - float(amb[0]))
        < 0.3
    )
    res = thermrs.campaign([sim.recording], tmp_path / "ds", rig=rig)
    runs = thermrs.analyses.inputs.select_runs(res.dataset)
    assert runs.sort("start_ns")["date"].cast(pl.String).to_list() == ["2026-11-02", "2026-11-03"]


def test_the_truth_alone_is_the_recordings_truth_and_writes_nothing(
    tmp_path: Path, paper_rig: thermrs.Rig
) -> None:
    """`simulate_truth` (no pixel rendered) gives the truth `simulate` writes beside its
    recording, every column equal, and leaves no file."""
    from polars.testing import assert_frame_equal
    from thermrs.simulate import simulate_truth

    sc = short(tmp_path, extra='[[effect]]\nname = "thermal_lag"\ntau_min = 40.0\n')
    sim = simulate(paper_rig, sc, tmp_path / "sim.mcap")
    before = sorted(tmp_path.iterdir())
    only = simulate_truth(paper_rig, sc)
    assert sorted(tmp_path.iterdir()) == before
    assert_frame_equal(only.frames, sim.frames)
    assert_frame_equal(only.samples, sim.samples)
    assert only.scenario == sim.scenario
    # The file's truth is what extraction measures (the round trip above), so this is too.
    assert_frame_equal(only.frames, pl.read_parquet(tmp_path / "sim.truth.parquet"))


def test_without_nodes_a_rig_gets_the_calibrated_nodes_of_the_rois_it_has(
    tmp_path: Path, paper_rig: thermrs.Rig
) -> None:
    """The paper rig without its base ROI simulates a scenario without ``[[node]]`` with the
    calibration's link 2 and link 3 nodes: their temperatures are the full rig's, every
    one (the nodes are independent), and no base column exists."""
    from thermrs.simulate import simulate_truth

    d = paper_rig.to_dict()
    d["thermal"]["roi"] = [r for r in d["thermal"]["roi"] if r["name"] != "base"]
    two = thermrs.Rig.from_dict(d, source_name="paper rig without base")
    sc = short(tmp_path)
    full = simulate_truth(paper_rig, sc).samples
    part = simulate_truth(two, sc).samples
    assert "base_surface_c" in full.columns and "base_surface_c" not in part.columns
    for col in ("link2_surface_c", "link3_surface_c", "link2_structure_c", "ambient_c"):
        assert np.array_equal(part[col].to_numpy(), full[col].to_numpy()), col


def test_a_simulation_in_another_thread_stops_when_cancelled(
    tmp_path: Path, paper_rig: thermrs.Rig
) -> None:
    """Signals reach only the main thread: a simulation in a worker thread stops on its
    ``cancel`` within a fraction of a second, with ``KeyboardInterrupt`` and no file left; an
    extraction there stops on a progress callback that raises."""
    import threading
    import time

    long = tmp_path / "long.toml"
    long.write_text(
        SHORT.format(compression="none").replace("duration_min = 60", "duration_min = 6000")
    )
    stop = threading.Event()
    caught: list[BaseException] = []

    def work() -> None:
        try:
            simulate(paper_rig, long, tmp_path / "long.mcap", cancel=stop.is_set)
        except BaseException as e:  # what the thread raised is the result
            caught.append(e)

    th = threading.Thread(target=work)
    th.start()
    time.sleep(0.5)
    assert th.is_alive()
    t0 = time.perf_counter()
    stop.set()
    th.join(timeout=5)
    assert not th.is_alive()
    assert time.perf_counter() - t0 < 0.5
    assert len(caught) == 1 and isinstance(caught[0], KeyboardInterrupt)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["long.toml"]

    rec = simulate(paper_rig, short(tmp_path, "none"), tmp_path / "sim.mcap").recording

    def refuse(done: int, total: int, frames: int) -> None:
        raise KeyboardInterrupt("cancelled")

    with pytest.raises(KeyboardInterrupt):
        thermrs.extract(rec, paper_rig, progress=refuse)


def test_a_mount_with_inertia_moves_the_truth_with_the_room_lagged(
    tmp_path: Path, paper_rig: thermrs.Rig
) -> None:
    """fixture_drift on camera A whose mount follows the room through 30 min: A's true spot
    moves by um_per_k·(T_m − reference), T_m the room (drifting 1 K/h) through a first-order
    lag integrated here on a fine grid (an implementation of its own); B's does not move."""
    from thermrs.bench import first_order_lag
    from thermrs.simulate import simulate_truth

    room = "[ambient]\nstart_c = 22.0\ndrift_c_per_h = 1.0\n"
    base = simulate_truth(paper_rig, short(tmp_path, extra=room)).frames
    eff = short(
        tmp_path,
        extra=room + '[[effect]]\nname = "fixture_drift"\ncamera = "A"\n'
        "um_per_k = [4.0, -2.0]\nmount_tau_min = 30.0\n",
    )
    moved = simulate_truth(paper_rig, eff).frames
    j = base.join(moved, on=["camera", "t_ns"], suffix="_e")
    b = j.filter(camera="B")
    assert np.allclose(b["x_px"], b["x_px_e"]) and np.allclose(b["y_px"], b["y_px_e"])
    a = j.filter(camera="A")
    t = (a["t_ns"].to_numpy() - 1_750_000_000 * 10**9) / 1e9 + 0.005
    grid = np.linspace(0.0, t.max() + 60.0, 20_001)
    mount = np.interp(t, grid, first_order_lag(grid, 22.0 + grid / 3600.0, 30 * 60.0))
    ref = paper_rig.reference_c
    got_u = (a["x_px_e"] - a["x_px"]).to_numpy() * 8.6
    got_v = (a["y_px_e"] - a["y_px"]).to_numpy() * 8.3
    assert np.allclose(got_u, 4.0 * (mount - ref), atol=0.02)
    assert np.allclose(got_v, -2.0 * (mount - ref), atol=0.02)
    # Not the room's own temperature: an hour in, the mount trails it by ~0.4 K.
    assert np.max(np.abs(got_u - 4.0 * (22.0 + t / 3600.0 - ref))) > 1.0
