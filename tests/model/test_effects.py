"""The SPEC §6 effects that act on geometry, against closed forms and equivalent rigs."""

from __future__ import annotations

import math
from pathlib import Path

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


# --- the effects' one home (issue #9) ---------------------------------------------------------


def test_effect_names_are_the_spec_table() -> None:
    from thermrs.effects import EFFECT_NAMES, effect_classes

    spec = [
        "alpha_per_link",
        "thermal_lag",
        "unmodelled_length",
        "fixture_drift",
        "laser_tilt",
        "joint_offset",
        "nonlinear_alpha",
        "sensor_drift",
    ]
    assert list(EFFECT_NAMES) == spec
    assert list(effect_classes())[: len(spec)] == spec


@pytest.mark.parametrize(
    ("effect", "key"),
    [
        ({"name": "thermal_lag", "tau_min": -5.0}, "tau_min"),  # once silently "no lag"
        ({"name": "sensor_drift", "camera": "A", "tau_min": 0.0, "um": [1, 1]}, "tau_min"),
        ({"name": "alpha_per_link", "alpha_per_k": {"link2": 23.2}}, "alpha_per_k.link2"),
        ({"name": "nonlinear_alpha", "kappa_per_k": 2.0}, "kappa_per_k"),
        ({"name": "laser_tilt", "tilt_deg": 30.0}, "tilt_deg"),
        ({"name": "fixture_drift", "camera": "A", "um_per_k": [1e5, 0]}, "um_per_k"),
        ({"name": "thermal_lag", "tau": 5.0}, "tau"),
    ],
)
def test_effect_values_are_range_checked(effect: dict[str, object], key: str) -> None:
    from thermrs.effects import from_dict

    with pytest.raises(thermrs.InputError, match=key):
        from_dict(effect)


def test_scenario_effects_are_checked_in_the_same_place(tmp_path: Path) -> None:
    sc = tmp_path / "s.toml"
    sc.write_text(
        'format = "thermrs-scenario/1"\n[[run]]\nname = "r"\nspeed_pct = 30\n'
        'duration_min = 10\ncycle_s = 60\n[[effect]]\nname = "thermal_lag"\ntau_min = -3\n'
    )
    from thermrs.simulate import simulate

    with pytest.raises(thermrs.ThermrsError, match=r"effect\[0\]\.tau_min"):
        simulate(thermrs.load_rig(), sc, tmp_path / "x.mcap")


def test_effects_and_keywords_build_the_same_model(paper_rig: thermrs.Rig) -> None:
    from thermrs.effects import JointOffset, UnmodelledLength

    rng = np.random.default_rng(3)
    q = rng.uniform(-1, 1, (50, 6))
    temps = {"link2": rng.uniform(20, 40, 50), "link3": rng.uniform(20, 40, 50)}
    a = ForwardModel(
        paper_rig,
        effects=[
            UnmodelledLength(length="a3", temperature="link3"),
            JointOffset(joint="joint_a2", temperature="link2", urad_per_k=7.0),
        ],
    )
    b = ForwardModel(
        paper_rig, extra_lengths={"a3": "link3"}, joint_offsets=[("joint_a2", "link2", 7.0)]
    )
    assert np.array_equal(
        a.flange_positions(q, temperatures=temps), b.flange_positions(q, temperatures=temps)
    )


def test_lag_and_chip_shifts_match_independent_closed_forms(paper_rig: thermrs.Rig) -> None:
    from thermrs.bench import first_order_lag
    from thermrs.effects import FixtureDrift, SensorDrift, ThermalLag

    t = np.linspace(0, 6 * 3600, 400)
    x = 23 + 6 * (1 - np.exp(-t / 5000)) + 0.3 * np.sin(t / 900)
    m = ForwardModel(paper_rig, effects=[ThermalLag(tau_min=40.0)])
    got = m._native.structure_temperatures(t, x)
    assert np.max(np.abs(got - first_order_lag(t, x, 40 * 60.0))) < 1e-9
    amb = 23 + 0.1 * t / 3600
    m = ForwardModel(
        paper_rig,
        effects=[
            FixtureDrift(camera="A", um_per_k=(2.0, -1.0)),
            SensorDrift(camera="A", tau_min=30.0, um=(5.0, 3.0)),
        ],
    )
    d = m._native.chip_shifts("A", amb, t)
    f = 1 - np.exp(-t / 1800.0)
    ref = paper_rig.reference_c
    assert np.allclose(d[:, 0], 2.0 * (amb - ref) + 5.0 * f, atol=1e-12)
    assert np.allclose(d[:, 1], -1.0 * (amb - ref) + 3.0 * f, atol=1e-12)
    assert np.all(m._native.chip_shifts("B", amb, t) == 0)
    # A mount with inertia follows the room through its own first-order lag (independent
    # implementation), and only its own camera's.
    amb = 23 + 0.8 * np.sin(t / 3000) + 0.2 * t / 3600
    m = ForwardModel(
        paper_rig, effects=[FixtureDrift(camera="A", um_per_k=(2.0, -1.0), mount_tau_min=25.0)]
    )
    assert m._native.has_mount_lag("A") and not m._native.has_mount_lag("B")
    mount = m._native.mount_temperatures("A", t, amb)
    assert np.max(np.abs(mount - first_order_lag(t, amb, 25 * 60.0))) < 1e-9
    d = m._native.chip_shifts("A", amb, t, mount)
    assert np.allclose(d[:, 0], 2.0 * (mount - ref), atol=1e-12)
    assert np.allclose(d[:, 1], -1.0 * (mount - ref), atol=1e-12)
    assert np.array_equal(m._native.mount_temperatures("B", t, amb), amb)


def test_a_users_own_effect_enters_the_diagnoser(paper_rig: thermrs.Rig) -> None:
    """An effect class written in Python (here: a chip that drifts linearly with time) is read
    and fitted like the built-in ones."""
    from dataclasses import dataclass
    from typing import Any, ClassVar

    from thermrs.bench import make_runs
    from thermrs.diagnose import diagnose
    from thermrs.effects import Effect, Family, ThermalLag
    from thermrs.signatures import VisitSet

    @dataclass(frozen=True)
    class LinearCreep(Effect):
        name: ClassVar[str] = "linear_creep"

        @classmethod
        def families(cls, rig: thermrs.Rig, visits: VisitSet) -> list[Family]:
            def columns(vs: VisitSet, eta: dict[str, float]) -> np.ndarray:
                t_h = vs.t_since_start / 3600.0
                z = np.zeros_like(t_h)
                return np.column_stack([np.concatenate([t_h, z]), np.concatenate([z, t_h])])

            def params(eta: Any, alpha: float, beta: np.ndarray, cov: np.ndarray) -> Any:
                return {"um_per_h": [float(beta[0]), float(beta[1])]}, {}

            return [Family(cls.name, cls.name, {}, [{}], columns, params, driver="time")]

    runs = make_runs(paper_rig, None, seed=21, hours=4.0)
    d = diagnose(runs[:1], runs[1:], paper_rig, library=[ThermalLag, LinearCreep], bootstrap=0)
    assert {r["effect"] for r in d.ranking} == {"thermal_lag", "linear_creep"}
    # No chip creeps in these runs: the user's effect is ranked, never named.
    assert "linear_creep" not in d.verdict["effects"]


def test_a_kappa_estimated_past_the_bound_is_held_at_it(paper_rig: thermrs.Rig) -> None:
    """The bound the core enforces is the one the family holds its estimate to: κ = 0.105 ±
    0.01 (1.96 sd) reads as the bound with the part of its interval inside it; one wholly past
    it is left there (no physical κ: not plausible)."""
    from thermrs.effects import KAPPA_PER_K_MAX, NonlinearAlpha, from_dict
    from thermrs.errors import InputError

    from_dict({"name": "nonlinear_alpha", "kappa_per_k": -KAPPA_PER_K_MAX})
    with pytest.raises(InputError, match="kappa_per_k"):
        from_dict({"name": "nonlinear_alpha", "kappa_per_k": KAPPA_PER_K_MAX * 1.0001})
    fam = NonlinearAlpha.families(paper_rig, None)[0]  # type: ignore[arg-type]
    alpha = 2e-5
    sd = 0.01 / 1.96
    # β = κ·α with var(β) = (sd·α)² and α known exactly: κ's delta-method sd is sd.
    cov = np.diag([0.0, (sd * alpha) ** 2])
    p, ci = fam.params({}, alpha, np.array([0.105 * alpha]), cov)
    assert p["kappa_per_k"] == KAPPA_PER_K_MAX
    assert ci["kappa_per_k"] == pytest.approx([0.095, KAPPA_PER_K_MAX])
    p, ci = fam.params({}, alpha, np.array([0.13 * alpha]), cov)
    assert p["kappa_per_k"] == pytest.approx(0.13)
    assert ci["kappa_per_k"] == pytest.approx([0.12, 0.14])
    p, ci = fam.params({}, alpha, np.array([-0.05 * alpha]), cov)
    assert p["kappa_per_k"] == pytest.approx(-0.05)
    assert ci["kappa_per_k"] == pytest.approx([-0.06, -0.04])
