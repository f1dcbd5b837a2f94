"""The parametric null's least squares: a model's columns added to its factorisation give the
least squares solved from scratch (numpy's ``lstsq`` on the stacked design), and a column
already in the model's span is refused as the full fit refuses it."""

from __future__ import annotations

import numpy as np
import pytest
import thermrs
from thermrs.bench import make_runs
from thermrs.diagnose.family_fit import DesignMatrix
from thermrs.diagnose.null import Batch
from thermrs.signatures import VisitSet


@pytest.fixture(scope="module")
def batch() -> Batch:
    rig = thermrs.load_rig()
    runs = make_runs(rig, None, seed=3, hours=4.0, cycle_s=300.0)
    vs = VisitSet(runs, rig)
    return Batch(DesignMatrix(vs, {"train"}), window_s=900.0)


def _lstsq(b: Batch, cols: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Training residual sum of squares and held-out mean square from numpy's lstsq: α, the
    columns and the training mountings fitted on the weighted training rows; the held-out
    runs' mountings as their residuals' weighted means."""
    d = b.d
    x_all = np.column_stack([d.s, cols])
    x = np.column_stack([x_all[b.tr], b.off_tr]) * b.sw[b.tr, None]
    coef, *_ = np.linalg.lstsq(x, y[b.tr] * b.sw[b.tr, None], rcond=None)
    rss = np.sum((y[b.tr] * b.sw[b.tr, None] - x @ coef) ** 2, axis=0)
    r = y[b.ho] - x_all[b.ho] @ coef[: x_all.shape[1]]
    for g in range(b.off_ho.shape[1]):
        rows = b.off_ho[:, g] > 0
        w = b.w_ho[rows]
        r[rows] -= (w @ r[rows]) / w.sum()
    return rss, np.mean(r**2, axis=0)


@pytest.mark.parametrize("added", [1, 2, 3])
def test_columns_added_to_a_factored_model_are_the_stacked_least_squares(
    batch: Batch, added: int
) -> None:
    rng = np.random.default_rng(added)
    rows = 2 * batch.d.vs.n
    t = np.linspace(0.0, 1.0, rows)
    model_cols = np.column_stack([np.sin(3 * t), t**2]) * 5.0
    new = np.column_stack([np.cos(k * 7 * t) + rng.normal(0, 0.1, rows) for k in range(added)])
    y = rng.normal(0, 2.0, (rows, 40)) + 3.0 * model_cols[:, :1] + 0.5 * new[:, :1]
    obs = batch.prepare(y)
    nested = batch.nested(["m1", "m2"], model_cols, obs)
    assert nested is not None
    got = batch.fit_added(nested, new, obs)
    assert got is not None
    rss, hold = _lstsq(batch, np.column_stack([model_cols, new]), y)
    np.testing.assert_allclose(got.train_rss, rss, rtol=1e-9)
    np.testing.assert_allclose(got.hold_ms, hold, rtol=1e-9)
    full = batch.fit(np.column_stack([model_cols, new]), obs)
    assert full is not None
    np.testing.assert_allclose(got.hold_ms, full.hold_ms, rtol=1e-9)


def test_a_column_in_the_models_span_is_refused_as_the_full_fit_refuses_it(
    batch: Batch,
) -> None:
    rows = 2 * batch.d.vs.n
    y = np.random.default_rng(0).normal(0, 1.0, (rows, 5))
    obs = batch.prepare(y)
    nested = batch.nested([], None, obs)
    assert nested is not None
    mounting = batch.d.offsets[:, [int(batch.used[0])]]
    alpha_twice = 2.0 * batch.d.s[:, None]
    for col in (mounting, alpha_twice):
        assert batch.fit(col, obs) is None
        assert batch.fit_added(nested, col, obs) is None


def test_the_correlated_part_is_a_stationary_ar1_in_time() -> None:
    # Closed form: variance σ_a² at every visit, correlation exp(−Δt/τ) across any gap.
    from thermrs.diagnose.floor import SeriesNoise
    from thermrs.diagnose.null import _ar

    t = np.array([0.0, 60.0, 400.0, 460.0, 2000.0])
    s = SeriesNoise(
        "r", "A", "u", 5, white_um=1.0, correlated_um=2.0, tau_c_s=300.0, centroid_um=None
    )
    z = np.random.default_rng(7).standard_normal((len(t), 40_000))
    x = _ar(t, z, s)
    np.testing.assert_allclose(np.var(x, axis=1), 4.0, rtol=0.03)
    for i in range(1, len(t)):
        r = np.corrcoef(x[i - 1], x[i])[0, 1]
        assert abs(r - np.exp(-(t[i] - t[i - 1]) / 300.0)) < 0.02
