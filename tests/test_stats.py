"""thermrs.stats against known truth: closed forms, statsmodels (an independent implementation
of OLS and Newey–West) and Monte Carlo over series whose error law is known."""

from __future__ import annotations

import numpy as np
import pytest
from thermrs.stats import effective_sample_size, lstsq_qr, moving_block_indices

sm = pytest.importorskip("statsmodels.api")


def ar1(rng: np.random.Generator, n: int, rho: float, sd: float, size: int = 1) -> np.ndarray:
    """Stationary AR(1) series (size × n) with marginal standard deviation sd."""
    e = rng.normal(0, sd * np.sqrt(1 - rho**2), (size, n))
    out = np.empty((size, n))
    out[:, 0] = rng.normal(0, sd, size)
    for t in range(1, n):
        out[:, t] = rho * out[:, t - 1] + e[:, t]
    return out


def ill_scaled_design(rng: np.random.Generator, n: int = 120) -> np.ndarray:
    """A sensitivity column of order 10⁷ beside three group-offset columns (the α fit's shape)."""
    s = 4e6 * (1 - np.exp(-np.arange(n) / 30.0)) + 1e6
    g = np.arange(n) % 3
    x = np.zeros((n, 4))
    x[:, 0] = s * (1 + 0.3 * g)
    x[np.arange(n), 1 + g] = 1.0
    return x


def test_qr_keeps_every_direction_of_an_ill_scaled_design() -> None:
    rng = np.random.default_rng(1)
    x = ill_scaled_design(rng)
    beta = np.array([23.2e-6, 3.0, -40.0, 12.0])
    y = x @ beta + rng.normal(0, 1.0, len(x))
    fit = lstsq_qr(x, y)
    ref = sm.OLS(y, x).fit()
    np.testing.assert_allclose(fit.coef, ref.params, rtol=1e-9)
    np.testing.assert_allclose(fit.stderr(), ref.bse, rtol=1e-9)
    # The defect this replaces: pinv of the normal matrix at numpy's default cutoff drops the
    # offsets' directions and understates α's standard error.
    naive = np.sqrt(fit.sigma2 * np.linalg.pinv(x.T @ x)[0, 0])
    assert naive < 0.5 * fit.stderr()[0]
    # Exact data: exact coefficients.
    np.testing.assert_allclose(lstsq_qr(x, x @ beta + 0 * y, None).coef, beta, rtol=1e-10)


def test_rank_deficient_design_raises() -> None:
    x = np.ones((10, 2))
    with pytest.raises(ValueError, match="rank deficient"):
        lstsq_qr(x, np.arange(10.0))


def test_weighted_fit_matches_statsmodels_wls() -> None:
    rng = np.random.default_rng(2)
    x = ill_scaled_design(rng)
    w = rng.uniform(0.2, 5.0, len(x))
    y = x @ np.array([2e-5, 1.0, 2.0, 3.0]) + rng.normal(0, 1, len(x)) / np.sqrt(w)
    fit = lstsq_qr(x, y, w)
    ref = sm.WLS(y, x, weights=w).fit()
    np.testing.assert_allclose(fit.coef, ref.params, rtol=1e-9)
    np.testing.assert_allclose(fit.stderr(), ref.bse, rtol=1e-9)


def test_hac_matches_statsmodels_newey_west() -> None:
    rng = np.random.default_rng(3)
    n = 200
    t = np.arange(n)
    x = np.column_stack([np.ones(n), 1 - np.exp(-t / 50)])
    y = x @ np.array([1.0, 2.0]) + ar1(rng, n, 0.8, 1.0)[0]
    fit = lstsq_qr(x, y, covariance="hac", bandwidth=7, prewhiten=False)
    ref = sm.OLS(y, x).fit(cov_type="HAC", cov_kwds={"maxlags": 7, "use_correction": True})
    np.testing.assert_allclose(fit.cov, ref.cov_params(), rtol=1e-9)


def test_hac_units_sum_rows_of_one_visit() -> None:
    """Two rows per unit (a visit's u and v): the unit score is their sum, so a design where
    u and v rows are exact copies gives the same covariance as one row per unit with doubled
    score, i.e. 4× the meat and the bread of the doubled design."""
    rng = np.random.default_rng(4)
    n = 100
    x1 = np.column_stack([np.ones(n), np.linspace(0, 1, n)])
    y1 = x1 @ np.array([0.5, 1.0]) + ar1(rng, n, 0.5, 1.0)[0]
    x2 = np.repeat(x1, 2, axis=0)
    y2 = np.repeat(y1, 2)
    units = np.repeat(np.arange(n), 2)
    one = lstsq_qr(x1, y1, covariance="hac", bandwidth=3, prewhiten=False)
    two = lstsq_qr(x2, y2, covariance="hac", units=units, bandwidth=3, prewhiten=False)
    # bread halves, meat quadruples: same covariance up to the n/(n−p) factors.
    k1, k2 = n / (n - 2), 2 * n / (2 * n - 2)
    np.testing.assert_allclose(two.cov / k2, one.cov / k1, rtol=1e-10)


@pytest.mark.parametrize("rho", [0.0, 0.6, 0.9])
def test_effective_sample_size_of_ar1(rho: float) -> None:
    """The variance of the mean of an AR(1) series of N samples is σ²/N_eff with N_eff ≈
    N(1−ρ)/(1+ρ); both estimators find it within 20 % on average over series (30 % at
    ρ = 0.9, where 400 samples' autocorrelations read low and N_eff comes out high)."""
    rng = np.random.default_rng(5)
    n = 400
    xs = ar1(rng, n, rho, 1.0, size=200)
    truth = n * (1 - rho) / (1 + rho)
    for method in ("ar1", "geyer"):
        est = np.mean([effective_sample_size(x, method=method) for x in xs])  # type: ignore[arg-type]
        assert est == pytest.approx(truth, rel=0.3 if rho > 0.8 else 0.2), (method, est, truth)
    # Monte Carlo check of the closed form itself.
    assert np.var(xs.mean(axis=1)) == pytest.approx(1.0 / truth, rel=0.25)


def test_moving_block_indices_keep_groups_and_blocks() -> None:
    rng = np.random.default_rng(6)
    groups = np.array(["a"] * 10 + ["b"] * 7)
    draw = next(moving_block_indices(groups, block_length=3, rng=rng))
    assert len(draw) == 17
    assert set(draw[:10]) <= set(range(10)) and set(draw[10:]) <= set(range(10, 17))
    # Within a group, blocks are runs of consecutive units.
    assert all(draw[i + 1] == draw[i] + 1 for i in (0, 1, 3, 4, 6, 7))


def test_block_bootstrap_recovers_the_variance_of_an_ar1_mean() -> None:
    rng = np.random.default_rng(7)
    n, rho = 600, 0.7
    x = ar1(rng, n, rho, 1.0)[0]
    gen = moving_block_indices(np.zeros(n), block_length=25, rng=rng)
    means = [x[next(gen)].mean() for _ in range(800)]
    truth = (1 + rho) / (1 - rho) / n  # variance of the mean, large-N
    assert np.var(means) == pytest.approx(truth, rel=0.35)


def test_hac_interval_covers_under_ar1_and_correlated_axes() -> None:
    """Series of visits (u, v per visit, AR(1) ρ 0.7 per axis, u–v correlation 0.6, offsets
    per series): the prewhitened-HAC 95 % interval of the slope covers the truth at close to
    the nominal rate and its half-width matches 1.96 × the true spread of the estimate, where
    the iid interval is far too narrow."""
    rng = np.random.default_rng(8)
    n_vis, trials, true = 150, 200, 2.0
    t = np.arange(n_vis, dtype=float)
    s = 1 - np.exp(-t / 50)
    est, half, cover, iid_cover = [], [], 0, 0
    for _ in range(trials):
        rows_x, rows_y, series, units = [], [], [], []
        for cam in range(2):
            eu = ar1(rng, n_vis, 0.7, 1.5)[0]
            ev = 0.6 * eu + 0.8 * ar1(rng, n_vis, 0.7, 1.5)[0]
            for ax, e in (("u", eu), ("v", ev)):
                sens = s * (1.0 if ax == "u" else -0.5) * (1 + cam)
                col = np.zeros((n_vis, 5))
                col[:, 0] = sens
                col[:, 1 + 2 * cam + (ax == "v")] = 1.0
                rows_x.append(col)
                rows_y.append(true * sens + 10 * cam + e)
                series += [cam] * n_vis
                units += list(range(n_vis))
        x, y = np.vstack(rows_x), np.concatenate(rows_y)
        order = np.tile(t, 4)
        f = lstsq_qr(x, y, covariance="hac", series=series, units=units, order=order)
        lo, hi = f.interval(0)
        est.append(f.coef[0])
        half.append((hi - lo) / 2)
        cover += lo <= true <= hi
        o = lstsq_qr(x, y)
        ilo, ihi = o.interval(0)
        iid_cover += ilo <= true <= ihi
    assert 0.91 <= cover / trials <= 0.99, cover / trials
    assert iid_cover / trials < 0.75, iid_cover / trials
    ratio = np.mean(half) / (1.96 * np.std(est))
    assert 0.9 < ratio < 1.4, ratio
