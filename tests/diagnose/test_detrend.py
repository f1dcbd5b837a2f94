"""The detrended noise model's design against its definition and against simulated noise."""

from __future__ import annotations

import numpy as np
import pytest
from thermrs.diagnose import detrend
from thermrs.diagnose.floor import _tau_grid


def _times(n: int, dt: float, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    t = np.cumsum(rng.uniform(0.9 * dt, 1.1 * dt, n))
    return np.delete(t, [5, n // 3, n // 3 + 1, n // 2])  # missing visits


@pytest.mark.parametrize(("n", "bandwidth_s"), [(900, 3000.0), (900, 1500.0), (1200, 3000.0)])
def test_the_low_rank_design_is_the_dense_one(n: int, bandwidth_s: float) -> None:
    # The dense products (I − S) Σ (I − S)ᵀ, n³ per τ, are the design's definition.
    t = _times(n, 60.0, n)
    lags = np.arange(1, 103)
    # Every fourth τ of the floor's grid, its ends among them (each τ is n³ of the reference).
    grid = _tau_grid(60.0, bandwidth_s / 1.7)
    taus = np.unique(np.append(grid[::4], grid[-1]))
    a = detrend.detrender(t, bandwidth_s)
    white, corr = detrend._dense(t, a, lags, taus)
    factor = detrend._low_rank(np.eye(len(t)) - a, np.random.default_rng(0))
    assert factor is not None and factor[0].shape[1] <= len(t) // 4
    w2, c2 = detrend._low_rank_design(t, factor[0], factor[1], lags, taus)
    np.testing.assert_allclose(w2, white, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(c2, corr, rtol=1e-9, atol=1e-12)
    # The public entry point, on times shifted by a day: the same columns.
    _, w3, c3 = detrend.detrended_design(t + 86_400.0, lags, taus, bandwidth_s)
    np.testing.assert_allclose(w3, white, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(c3, corr, rtol=1e-9, atol=1e-12)


def test_the_design_is_the_mean_semivariogram_of_detrended_simulated_noise() -> None:
    # Noise drawn from its covariance (white 1, exponential 1 over τ = 300 s), detrended, its
    # empirical semivariogram averaged over draws: the design's white + correlated columns.
    t = _times(240, 60.0, 7)
    lags = np.arange(1, 31)
    taus = np.array([0.0, 300.0])
    a, white, corr = detrend.detrended_design(t, lags, taus, 2400.0)
    cov = np.eye(len(t)) + np.exp(-np.abs(t[:, None] - t[None, :]) / 300.0)
    rng = np.random.default_rng(11)
    x = np.linalg.cholesky(cov) @ rng.standard_normal((len(t), 4000))
    y = a @ x
    emp = np.array([0.5 * np.mean((y[k:] - y[:-k]) ** 2) for k in lags])
    model = white + corr[1]
    # 4000 draws: the mean of each lag's 4000 × (n − k) squared differences is within a
    # percent or so of its expectation; 3 % is several standard errors.
    np.testing.assert_allclose(emp, model, rtol=0.03)
    assert np.all(corr[0] == 0.0)
