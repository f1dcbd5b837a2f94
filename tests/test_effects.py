"""The SPEC §6 effects that act on geometry, against closed forms and equivalent rigs."""

from __future__ import annotations

import math

import numpy as np
import pytest
import thermrs
from thermrs import ForwardModel


def test_unmodelled_length_equals_a_rig_that_lists_it(paper_rig: thermrs.Rig) -> None:
    text = thermrs.default_rig_path().read_text()
    listed = thermrs.Rig.from_toml(
        text.replace(
            '{ name = "d4", temperature = "link3" },',
            '{ name = "d4", temperature = "link3" },\n    { name = "a3", temperature = "link3" },',
        )
    )
    assert [m.name for m in listed.lengths] == ["a2", "d4", "a3"]
    rng = np.random.default_rng(5)
    q = rng.uniform(-np.pi, np.pi, (200, 6))
    temps = {"link2": rng.uniform(15, 45, 200), "link3": rng.uniform(15, 45, 200)}
    effect = ForwardModel(paper_rig, extra_lengths={"a3": "link3"})
    want = ForwardModel(listed).flange_positions(q, temperatures=temps)
    got = effect.flange_positions(q, temperatures=temps)
    assert np.max(np.abs(got - want)) < 1e-9
    # And it does something: a3 = 152.91 mm at 20 K over reference moves the flange µm-scale.
    base = ForwardModel(paper_rig).flange_positions(q, temperatures=temps)
    assert np.max(np.abs(got - base)) > 0.01
    with pytest.raises(thermrs.InputError, match="already expands"):
        ForwardModel(paper_rig, extra_lengths={"a2": "link2"})
    with pytest.raises(thermrs.InputError, match="0 mm"):
        ForwardModel(paper_rig, extra_lengths={"a4": "link2"})
    with pytest.raises(thermrs.InputError, match="neither a ROI"):
        ForwardModel(paper_rig, extra_lengths={"a3": "link9"})


def test_unmodelled_length_can_bring_a_new_temperature(paper_rig: thermrs.Rig) -> None:
    m = ForwardModel(paper_rig, extra_lengths={"d1": "base"})
    assert m.temperature_names == ["link2", "link3", "base"]
    q = np.zeros(6)
    lo = m.flange_positions(q, temperatures={"link2": 23.0, "link3": 23.0, "base": 23.0})[0]
    hi = m.flange_positions(q, temperatures={"link2": 23.0, "link3": 23.0, "base": 33.0})[0]
    # d1 = 675 mm along base z: +10 K lifts the flange by 675·α·10.
    assert hi - lo == pytest.approx([0, 0, 675.0 * 2.32e-5 * 10], abs=1e-12)


def test_joint_offset_on_joint_1_rotates_about_base_z(paper_rig: thermrs.Rig) -> None:
    k_urad = 50.0  # µrad/K
    m = ForwardModel(paper_rig, joint_offsets=[("joint_a1", "base", k_urad)])
    q = paper_rig.poses["A"].joints_rad
    nominal = {"link2": 23.0, "link3": 23.0, "base": 23.0}
    p0 = m.flange_positions(q, temperatures=nominal)[0]
    p1 = m.flange_positions(q, temperatures={**nominal, "base": 33.0})[0]
    d = k_urad * 1e-6 * 10.0
    want = [p0[0] * math.cos(d) - p0[1] * math.sin(d), p0[0] * math.sin(d) + p0[1] * math.cos(d)]
    assert p1[:2] == pytest.approx(want, abs=1e-9)
    assert p1[2] == pytest.approx(p0[2], abs=1e-9)
    # By number too (1-based), and the name is checked.
    m2 = ForwardModel(paper_rig, joint_offsets=[(1, "base", k_urad)])
    assert m2.flange_positions(q, temperatures={**nominal, "base": 33.0})[0] == pytest.approx(p1)
    with pytest.raises(thermrs.InputError, match="joint_a9"):
        ForwardModel(paper_rig, joint_offsets=[("joint_a9", "base", 1.0)])


@pytest.mark.parametrize("tilt", [0.05, 0.5, 2.0])
@pytest.mark.parametrize("azimuth", [0.0, 90.0, 217.0])
def test_laser_tilt_moves_the_spot_by_distance_tan_tilt(
    paper_rig: thermrs.Rig, tilt: float, azimuth: float
) -> None:
    """Camera A is orthogonal to the laser at 106 mm: a tilt θ lands the spot 106·tan θ mm
    from the centre, at incidence θ, whatever the azimuth."""
    q = paper_rig.camera_pose("A").joints_rad
    s = ForwardModel(paper_rig, laser_tilt_deg=(tilt, azimuth)).spots("A", q)
    assert s.incidence_deg[0] == pytest.approx(tilt, abs=1e-6)
    r_um = math.hypot(s.u_um[0], s.v_um[0])
    assert r_um == pytest.approx(106.0 * math.tan(math.radians(tilt)) * 1000, rel=1e-6)


def test_temperature_names_follow_effects(paper_rig: thermrs.Rig) -> None:
    m = ForwardModel(
        paper_rig, extra_lengths={"a3": "base"}, joint_offsets=[("joint_a2", "link2", 3.0)]
    )
    assert m.temperature_names == ["link2", "link3", "base"]
    with pytest.raises(thermrs.InputError, match="missing"):
        m.flange_positions(np.zeros(6), temperatures={"link2": 1.0, "link3": 1.0})
