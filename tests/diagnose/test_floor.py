"""The noise floor's variogram fit, every replicate at once, against scipy's non-negative
least squares (Lawson–Hanson) fitted one series and one τ at a time."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import nnls
from thermrs.diagnose.floor import SCALE_SEPARATION, series_noise, series_noise_many


def reference(r: np.ndarray, t: np.ndarray, tau_c_max_s: float) -> tuple[float, ...] | None:
    """The constrained variogram (module docs of thermrs.diagnose.floor), one series, with
    scipy's nnls per τ."""
    ok = np.isfinite(r)
    r, t = r[ok], t[ok]
    if len(r) < 12:
        return None
    dt = float(np.median(np.diff(t)))
    k_max = int(np.clip(np.ceil(SCALE_SEPARATION * tau_c_max_s / dt), 4, len(r) // 3))
    lags = np.arange(1, k_max + 1)
    gam = np.array(
        [
            np.mean(np.sqrt(np.abs(r[k:] - r[:-k]))) ** 4 / (0.457 + 0.494 / (len(r) - k)) / 2
            for k in lags
        ]
    )
    h = lags * dt
    best = None
    grid = np.geomspace(max(dt / 4.0, 1.0), max(tau_c_max_s, dt / 4.0 + 1), 24)
    for tau in [0.0, *grid]:
        if tau > tau_c_max_s and tau > 0:
            continue
        corr = np.zeros_like(h) if tau == 0 else 1.0 - np.exp(-h / tau)
        coef, err = nnls(np.column_stack([np.ones_like(h), corr, (h / h[-1]) ** 2]), gam)
        if tau == 0:
            coef[1] = 0.0
        if best is None or err < best[0] - 1e-12:
            best = (err, coef[0], coef[1], tau)
    assert best is not None
    _, w2, a2, tau = best
    if tau < dt:
        w2, a2, tau = w2 + a2, 0.0, 0.0
    return float(np.sqrt(w2)), float(np.sqrt(a2)), float(tau)


def series(rng: np.random.Generator, n: int, b: int) -> tuple[np.ndarray, np.ndarray]:
    """``b`` residual series of ``n`` visits a minute apart: white noise, a pose error
    correlated over a few minutes of random strength, and a slow drift of random size; every
    third series without the correlated part and every fourth without the drift (fits on the
    boundary of the constraints)."""
    t = np.arange(n) * 60.0 + rng.uniform(0, 5, n)
    out = np.empty((n, b))
    for j in range(b):
        z = rng.standard_normal(n)
        ar = np.empty(n)
        ar[0] = z[0]
        phi = np.exp(-60.0 / rng.uniform(60, 900))
        for i in range(1, n):
            ar[i] = phi * ar[i - 1] + np.sqrt(1 - phi * phi) * z[i]
        drift = (j % 4 != 0) * rng.normal(0, 3) * (t / t[-1]) ** 2
        a = (j % 3 != 0) * rng.uniform(0, 2)
        out[:, j] = rng.uniform(0.2, 2) * rng.standard_normal(n) + a * ar + drift
    return t, out


@pytest.mark.parametrize("seed", range(4))
def test_every_replicate_at_once_is_the_one_at_a_time_fit(seed: int) -> None:
    rng = np.random.default_rng(seed)
    t, r = series(rng, int(rng.integers(40, 400)), 30)
    tau_c_max_s = float(rng.uniform(120, 3600))
    got = series_noise_many(r, t, tau_c_max_s)
    for j in range(r.shape[1]):
        want = reference(r[:, j], t, tau_c_max_s)
        assert want is not None
        np.testing.assert_allclose(got[j], want, rtol=1e-7, atol=1e-9)
        one = series_noise(r[:, j], t, tau_c_max_s)
        assert one is not None
        np.testing.assert_allclose(one, got[j], rtol=1e-12, atol=1e-12)


def test_missing_visits_and_short_series() -> None:
    """Columns with different missing visits are each fitted on their own visits; a series
    of fewer than 12 visits has no estimate."""
    rng = np.random.default_rng(7)
    t, r = series(rng, 120, 6)
    r[5, 1] = np.nan
    r[[7, 9, 50], 3] = np.nan
    r[11:, 5] = np.nan
    got = series_noise_many(r, t, 1800.0)
    for j in range(5):
        want = reference(r[:, j], t, 1800.0)
        assert want is not None
        np.testing.assert_allclose(got[j], want, rtol=1e-7, atol=1e-9)
    assert np.all(np.isnan(got[5]))
    assert series_noise(r[:, 5], t, 1800.0) is None
