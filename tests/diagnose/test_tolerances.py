"""The rig's tolerances about a model with effects: an IR reading's error moves every term of
the model that reads it, the effect's as well as the expansion's. Checked against the forward
model itself: the spots of the model with its effect, once with the true readings and once
with the readings in error."""

from __future__ import annotations

import numpy as np
import pytest
import thermrs
from thermrs.bench import make_runs
from thermrs.diagnose.tolerances import ModelNuisance
from thermrs.effects import Family, effect_classes, from_dict
from thermrs.signatures import VisitSet

LABEL = "joint_offset joint=joint_a2 temperature=link3"
URAD_PER_K = 12.0


@pytest.fixture(scope="module")
def visits() -> VisitSet:
    rig = thermrs.load_rig()
    return VisitSet(make_runs(rig, None, seed=3, hours=4.0, cycle_s=300.0), rig)


def _joint_offset(vs: VisitSet) -> tuple[Family, np.ndarray, object]:
    """The joint offset's family (``LABEL``), its columns on ``vs`` and the effect itself at
    ``URAD_PER_K``."""
    rig = vs.rig
    (family,) = [f for f in effect_classes()["joint_offset"].families(rig, vs) if f.label == LABEL]
    cols = np.asarray(family.columns(vs, {}), dtype=np.float64)
    spec = {"joint": "joint_a2", "temperature": "link3", "urad_per_k": URAD_PER_K}
    return family, cols, from_dict({"name": "joint_offset", **spec}, rig=rig)


def _spots(vs: VisitSet, temps: dict[str, np.ndarray], effect: object, alpha: float) -> np.ndarray:
    return vs.replaced(temps=temps).positions(effects=[effect], alpha_per_k=alpha)  # type: ignore[list-item]


@pytest.mark.parametrize("kind", ["drift", "gain"])
def test_an_ir_readings_error_moves_the_models_effect_as_the_forward_model_does(
    visits: VisitSet, kind: str
) -> None:
    vs = visits
    rig = vs.rig
    alpha = rig.alpha_per_k
    family, cols, effect = _joint_offset(vs)
    # The reading of link 3 in error by one standard uncertainty of the rig's tolerance.
    tol = rig.tolerances
    err = dict(vs.temps)
    if kind == "drift":
        span = {r: float(np.max(vs.t_since_start[vs.run == r])) for r in set(vs.run.tolist())}
        frac = vs.t_since_start / np.array([span[r] for r in vs.run])
        err["link3"] = vs.temps["link3"] + tol["ir_drift_k"] * frac
        names = [f"IR offset drift (link3, run {r})" for r in span]
    else:
        rise = vs.temps["link3"] - vs.temps["ambient"]
        err["link3"] = vs.temps["link3"] + tol["ir_gain"] * rise
        names = ["IR gain (link3)"]
    truth = _spots(vs, err, effect, alpha) - _spots(vs, dict(vs.temps), effect, alpha)

    mn = ModelNuisance(vs, rig, alpha, np.zeros((2 * vs.n, 0)))
    terms = [(family, {}, cols)]
    with_effect = dict(mn.ir_columns(terms, np.array([alpha, URAD_PER_K])))
    nominal = dict(mn.ir_columns([], np.array([alpha])))
    got = sum(with_effect[n] for n in names)
    scale = float(np.max(np.abs(truth)))
    assert scale > 0.05  # µm: a signature a statistic can feel
    np.testing.assert_allclose(got, truth, atol=0.01 * scale)
    # The nominal model's signature alone misses the effect's part of it.
    missed = float(np.max(np.abs(sum(nominal[n] for n in names) - truth)))
    assert missed > 0.2 * scale


def test_a_reading_changed_at_every_visit_moves_the_model_as_the_forward_model_does(
    visits: VisitSet,
) -> None:
    # Noise on link 3's reading, a different change at every visit (what the thermal
    # camera's reading noise is): the model with its effect moves as the forward model does.
    vs = visits
    rig = vs.rig
    alpha = rig.alpha_per_k
    family, cols, effect = _joint_offset(vs)
    d = np.random.default_rng(7).normal(0.0, 0.5, vs.n)
    err = {**vs.temps, "link3": vs.temps["link3"] + d}
    truth = _spots(vs, err, effect, alpha) - _spots(vs, dict(vs.temps), effect, alpha)
    mn = ModelNuisance(vs, rig, alpha, np.zeros((2 * vs.n, 0)))
    got = mn.moved([(family, {}, cols)], np.array([alpha, URAD_PER_K]), {"link3": d})
    scale = float(np.max(np.abs(truth)))
    assert scale > 0.5
    np.testing.assert_allclose(got, truth, atol=1e-3 * scale)
