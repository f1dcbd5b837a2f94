"""The forward model against known truth: the paper's Table 2, an independent FK library
(Peter Corke's Robotics Toolbox), and closed-form geometry."""

from __future__ import annotations

import threading

import numpy as np
import pytest
import thermrs
from thermrs import ForwardModel

rtb = pytest.importorskip("roboticstoolbox")


def rtb_robot(rig: thermrs.Rig, a: list[float] | None = None, d: list[float] | None = None):
    """The rig's DH chain built in the Robotics Toolbox (sign −1 is its ``flip``)."""
    links = []
    for i, row in enumerate(rig.dh):
        links.append(
            rtb.RevoluteDH(
                a=row.a_mm if a is None else a[i],
                alpha=np.radians(row.alpha_deg),
                d=row.d_mm if d is None else d[i],
                offset=np.radians(row.theta_offset_deg),
                flip=row.sign == -1,
            )
        )
    return rtb.DHRobot(links)


def test_table2_flange_coordinates(paper_rig: thermrs.Rig) -> None:
    m = ForwardModel(paper_rig)
    table2 = {"A": (1087.78, -48.62, 217.75), "B": (1087.33, -38.29, 198.07)}
    for pose, want in table2.items():
        got = m.flange_positions(paper_rig.poses[pose].joints_rad)[0]
        assert np.all(np.abs(got - want) < 0.1), (pose, got)


def test_camera_a_spot_at_chip_centre(paper_rig: thermrs.Rig) -> None:
    s = ForwardModel(paper_rig).spots("A", paper_rig.camera_pose("A").joints_rad)
    assert s.x_px[0] == pytest.approx(375.5, abs=1e-6)
    assert s.y_px[0] == pytest.approx(290.5, abs=1e-6)
    assert s.distance_mm[0] == pytest.approx(106.0, abs=1e-6)
    assert s.incidence_deg[0] < 1e-4
    assert s.on_chip[0]


def test_random_joints_agree_with_robotics_toolbox(paper_rig: thermrs.Rig) -> None:
    rng = np.random.default_rng(7)
    q = rng.uniform(-np.pi, np.pi, (2000, 6))
    ours = ForwardModel(paper_rig).flange_transforms(q)
    theirs = np.stack([T.A for T in rtb_robot(paper_rig).fkine(q)])
    assert np.max(np.abs(ours[:, :3, 3] - theirs[:, :3, 3])) < 1e-9  # mm
    assert np.max(np.abs(ours[:, :3, :3] - theirs[:, :3, :3])) < 1e-12


def test_expanded_lengths_agree_with_robotics_toolbox(paper_rig: thermrs.Rig) -> None:
    """Per-sample expansion equals a toolbox robot built with the expanded lengths."""
    rng = np.random.default_rng(11)
    alpha, ref = 23.2e-6, paper_rig.reference_c
    m = ForwardModel(paper_rig, alpha_per_k=alpha)
    for _ in range(20):
        q = rng.uniform(-np.pi, np.pi, 6)
        t2, t3 = rng.uniform(0.0, 80.0, 2)
        got = m.flange_positions(q, temperatures={"link2": t2, "link3": t3})[0]
        a = [row.a_mm for row in paper_rig.dh]
        d = [row.d_mm for row in paper_rig.dh]
        a[1] *= 1 + alpha * (t2 - ref)  # a2 <- link2
        d[3] *= 1 + alpha * (t3 - ref)  # d4 <- link3
        want = rtb_robot(paper_rig, a, d).fkine(q).t
        assert np.max(np.abs(got - want)) < 1e-9


def test_heating_link2_at_zero_pose_lengthens_reach_along_x() -> None:
    """Closed form: at q = 0 the KR 15's a2 (650 mm) lies along base x, so heating only
    link 2 by ΔT moves the flange by 650 mm·α·ΔT along x and nowhere else."""
    text = thermrs.default_rig_path().read_text()
    rig = thermrs.Rig.from_toml(text)
    m = ForwardModel(rig, alpha_per_k=1e-5)
    q0 = np.zeros(6)
    cold = m.flange_positions(q0, temperatures={"link2": 23.0, "link3": 23.0})[0]
    hot = m.flange_positions(q0, temperatures={"link2": 123.0, "link3": 23.0})[0]
    # Only a2 (650 mm, along base x at q = 0) grows: by 650·1e-5·100 = 0.65 mm.
    assert hot - cold == pytest.approx([0.65, 0.0, 0.0], abs=1e-9)


def test_nonlinear_and_per_link_alpha(paper_rig: thermrs.Rig) -> None:
    q = np.zeros(6)
    base = ForwardModel(paper_rig, alpha_per_k=1e-5)
    per = ForwardModel(paper_rig, alpha_per_k=1e-5, alpha_by_temperature={"link2": 2e-5})
    kap = ForwardModel(paper_rig, alpha_per_k=1e-5, kappa_per_k=0.01)
    temps = {"link2": 33.0, "link3": 23.0}
    x0 = base.flange_positions(q, temperatures=temps)[0, 0]
    assert per.flange_positions(q, temperatures=temps)[0, 0] - x0 == pytest.approx(0.065, abs=1e-9)
    # strain 1e-5·10·(1 + 0.01·10) = 1.1e-4 instead of 1e-4 on 650 mm
    assert kap.flange_positions(q, temperatures=temps)[0, 0] - x0 == pytest.approx(0.0065, abs=1e-9)
    with pytest.raises(thermrs.InputError, match="link9"):
        ForwardModel(paper_rig, alpha_by_temperature={"link9": 1e-5})


def test_millions_of_samples_in_one_call_with_progress(paper_rig: thermrs.Rig) -> None:
    n = 2_000_000
    q = np.broadcast_to(paper_rig.camera_pose("A").joints_rad, (n, 6))
    t = np.linspace(20.0, 40.0, n)
    calls: list[tuple[int, int]] = []
    s = ForwardModel(paper_rig).spots(
        "A",
        q,
        temperatures={"link2": t, "link3": t},
        progress=lambda d, tot: calls.append((d, tot)),
    )
    assert s.x_px.shape == (n,)
    assert calls[0] == (0, n) and calls[-1] == (n, n) and len(calls) > 2
    # Heating moves the spot monotonically along the chip y axis (base x).
    assert np.all(np.diff(s.y_px[:: n // 100]) > 0)
    single = ForwardModel(paper_rig).spots(
        "A", q[0], temperatures={"link2": t[n // 3], "link3": t[n // 3]}
    )
    assert s.y_px[n // 3] == single.y_px[0]


def test_gil_is_released_during_batches(paper_rig: thermrs.Rig) -> None:
    """Another Python thread keeps running while a long batch computes."""
    n = 3_000_000
    q = np.zeros((n, 6))
    ticks = 0
    done = threading.Event()

    def ticker() -> None:
        nonlocal ticks
        while not done.is_set():
            ticks += 1

    th = threading.Thread(target=ticker)
    th.start()
    ForwardModel(paper_rig).flange_positions(q)
    done.set()
    th.join()
    assert ticks > 1000


def test_bad_inputs_raise_typed_errors(paper_rig: thermrs.Rig) -> None:
    m = ForwardModel(paper_rig)
    with pytest.raises(thermrs.InputError, match=r"shape \(6,\) or \(N, 6\)"):
        m.flange_positions(np.zeros((3, 5)))
    with pytest.raises(thermrs.InputError, match="missing"):
        m.flange_positions(np.zeros(6), temperatures={"link2": 20.0})
    with pytest.raises(thermrs.InputError, match="not in the rig"):
        m.flange_positions(np.zeros(6), temperatures={"link2": 1.0, "link3": 1.0, "lnik3": 1.0})
    with pytest.raises(thermrs.InputError, match="broadcast"):
        m.flange_positions(np.zeros((3, 6)), temperatures={"link2": np.ones(4), "link3": 1.0})
    with pytest.raises(thermrs.ThermrsError, match="camera 'C'"):
        m.spots("C", np.zeros(6))


def test_outputs_are_owned_contiguous_arrays(paper_rig: thermrs.Rig) -> None:
    out = ForwardModel(paper_rig).flange_positions(np.zeros((10, 6)))
    assert out.dtype == np.float64 and out.flags.c_contiguous and out.flags.writeable
    assert out.shape == (10, 3)


def test_other_robot_with_chips_placed_by_the_toolbox() -> None:
    """fixtures/rigs/ur5-two-cameras.toml: a UR5 with a sign −1 joint, θ offsets and a tilted
    laser; its chips were placed by the Robotics Toolbox orthogonal to the ray at 120 / 95 mm
    (fixtures/make_ur5_rig.py). thermrs must find each spot at the chip's centre pixel."""
    from pathlib import Path

    rig = thermrs.load_rig(Path(__file__).parents[2] / "fixtures/rigs/ur5-two-cameras.toml")
    view = rig.check()
    for cam, pose, dist in (("near", "P1", 120.0), ("far", "P2", 95.0)):
        p = view["poses"][pose]
        assert p["spot_px"][cam] == pytest.approx([639.5, 511.5], abs=1e-6)
        assert p["incidence_deg"][cam] == pytest.approx(0.0, abs=1e-6)
        assert p["distance_mm"][cam] == pytest.approx(dist, abs=1e-9)
    # Ambient-mapped d1 expands too: warming the room lifts the flange by d1·α·ΔT.
    m = ForwardModel(rig)
    q = rig.poses["P1"].joints_rad
    t = {"upper_arm": 20.0, "forearm": 20.0}
    lo = m.flange_positions(q, temperatures={**t, "ambient": 20.0})[0]
    hi = m.flange_positions(q, temperatures={**t, "ambient": 30.0})[0]
    assert hi - lo == pytest.approx([0.0, 0.0, 89.159 * 2.3e-5 * 10], abs=1e-12)
