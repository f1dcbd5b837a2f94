"""The noise floor's variogram fit, every replicate at once, against scipy's non-negative
least squares (Lawson–Hanson) fitted one series and one τ at a time, and its estimates
against simulated truth, with and without a slow structure beside the noise."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import nnls
from thermrs.diagnose.floor import SCALE_SEPARATION, series_noise, series_noise_many


def detrender(t: np.ndarray, bandwidth: float) -> np.ndarray:
    """I − S, S the local quadratic smoother with a Gaussian kernel: row by row, the weighted
    least-squares fit's value at each time."""
    n = len(t)
    s = np.empty((n, n))
    for i in range(n):
        d = (t - t[i]) / bandwidth
        sw = np.sqrt(np.exp(-0.5 * d**2))
        x = np.column_stack([np.ones(n), d, d**2])
        # the fit's value at t_i is the first coefficient: a linear map of the data
        s[i] = np.linalg.pinv(x * sw[:, None])[0] * sw
    return np.eye(n) - s


def semivariogram(c: np.ndarray, k: int) -> float:
    """The mean semivariogram at lag ``k`` of a series with covariance ``c``."""
    d = np.diag(c)
    return float(np.mean(0.5 * (d[k:] + d[:-k] - 2 * np.diagonal(c, -k))))


def reference(r: np.ndarray, t: np.ndarray, tau_c_max_s: float) -> tuple[float, ...] | None:
    """The constrained variogram (module docs of thermrs.diagnose.floor), one series, with
    scipy's nnls per τ: detrended by the local quadratic, the white and correlated columns
    the detrended covariances' semivariograms, each lag weighted by √pairs over the
    log-variogram averaged over five neighbouring lags."""
    ok = np.isfinite(r)
    dt_all = float(np.median(np.diff(t)))  # the τ grid: from every visit of the series
    r, t = r[ok], t[ok]
    if len(r) < 12:
        return None
    dt = float(np.median(np.diff(t)))
    k_max = int(np.clip(np.ceil(SCALE_SEPARATION * tau_c_max_s / dt), 4, len(r) // 3))
    lags = np.arange(1, k_max + 1)
    a = detrender(t, 0.5 * SCALE_SEPARATION * tau_c_max_s)
    z = a @ r
    gam = np.array(
        [
            np.mean(np.sqrt(np.abs(z[k:] - z[:-k]))) ** 4 / (0.457 + 0.494 / (len(z) - k)) / 2
            for k in lags
        ]
    )
    lg = np.log(gam)
    w = np.array(
        [
            np.sqrt(len(z) - k)
            / np.exp(np.mean(lg[np.clip(np.arange(i - 2, i + 3), 0, len(lags) - 1)]))
            for i, k in enumerate(lags)
        ]
    )
    white = np.array([semivariogram(a @ a.T, int(k)) for k in lags])
    h = lags * dt
    best = None
    grid = np.geomspace(max(dt_all / 4.0, 1.0), max(tau_c_max_s, dt_all / 4.0 + 1), 24)
    for tau in [0.0, *grid]:
        if tau > tau_c_max_s and tau > 0:
            continue
        if tau == 0:
            corr = np.zeros_like(h)
        else:
            c = a @ np.exp(-np.abs(t[:, None] - t[None, :]) / tau) @ a.T
            corr = np.array([semivariogram(c, int(k)) for k in lags])
        x = np.column_stack([white, corr, (h / h[-1]) ** 2]) * w[:, None]
        coef, err = nnls(x, gam * w)
        if tau == 0:
            coef[1] = 0.0
        if best is None or err < best[0] - 1e-12:
            best = (err, coef[0], coef[1], tau)
    assert best is not None
    _, w2, a2, tau = best
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
        if j % 5 == 0:  # the dense reference (n³ per τ and column) on a fifth of them
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


def ou_run(
    rng: np.random.Generator, n: int, dt: float, tau: float, mix: np.ndarray, white: float, b: int
) -> np.ndarray:
    """``b`` replicates of a run's channels (n × k × b): a pose error of independent unit
    Ornstein–Uhlenbeck joints (correlation time ``tau``) seen through ``mix`` (k × joints),
    plus independent white noise of ``white`` per channel."""
    phi = np.exp(-dt / tau)
    q = np.empty((n, mix.shape[1], b))
    q[0] = rng.standard_normal(q.shape[1:])
    for i in range(1, n):
        q[i] = phi * q[i - 1] + np.sqrt(1 - phi * phi) * rng.standard_normal(q.shape[1:])
    out: np.ndarray = np.einsum("kj,njb->nkb", mix, q)
    return out + white * rng.standard_normal(out.shape)


def test_a_runs_pooled_correlation_time_is_the_worlds() -> None:
    """A pose error correlated over 15 min moving four channels (two chips, u and v) through
    one mixing, white noise beside it, 90 visits 10 min apart (a 15-h run), the largest
    allowed correlation time 24 min: the correlation time pooled over the run's channels has
    its median within 20 % of the truth, and every channel's σ_w² + σ_a² its mean within
    10 % of the world's variance; fitted channel by channel the median is further off."""
    from thermrs.diagnose.floor import pooled_noise

    rng = np.random.default_rng(20261202)
    n, dt, tau, cap, b = 90, 600.0, 900.0, 1440.0, 300
    mix = np.array([[0.9, 0.5, 0.2], [-0.3, 0.8, 0.6], [0.7, -0.4, 0.5], [0.2, 0.6, -0.9]])
    white = 1.0
    x = ou_run(rng, n, dt, tau, mix, white, b)
    t = np.arange(n) * dt
    got = pooled_noise([(x[:, c, :], t) for c in range(4)], cap)
    taus = np.array([g[:, 2] for g in got])
    assert np.all(taus == taus[0])  # one τ for the run
    assert abs(np.median(taus[0]) / tau - 1.0) < 0.2, np.median(taus[0])
    truth = np.sum(mix**2, axis=1) + white**2
    for c in range(4):
        var = np.mean(got[c][:, 0] ** 2 + got[c][:, 1] ** 2)
        assert abs(var / truth[c] - 1.0) < 0.1, (c, var, truth[c])
    one = series_noise_many(x[:, 0, :], t, cap)
    assert abs(np.median(one[:, 2]) / tau - 1.0) > abs(np.median(taus[0]) / tau - 1.0)


def test_channel_correlations_are_the_worlds() -> None:
    """The correlated parts of four channels moved by one pose error correlate as the
    mixing says (ρ = normalised M·Mᵀ: 0.99 between the first and last channel), their white
    parts not at all. From the cross-variograms of a campaign's three 15-h runs (lags to
    three correlation times; covariances averaged over the runs, then normalised), over 100
    campaigns: every entry's mean within 0.15 of the truth, the white parts' within 0.1 of
    none; the correlation of the cycle-to-cycle increments, which mixes the two parts,
    misses the strongest entry's by more than 0.5 on average, and its rms error over
    campaigns and entries is larger."""
    from thermrs.diagnose.floor import as_correlation, correlation_lags, cross_variogram_parts

    rng = np.random.default_rng(7)
    n, dt, tau = 90, 600.0, 900.0
    mix = np.array([[0.9, 0.5, 0.2], [-0.3, 0.8, 0.6], [0.7, -0.4, 0.5], [0.8, 0.6, 0.1]])
    cov = mix @ mix.T
    want = cov / np.sqrt(np.outer(np.diag(cov), np.diag(cov)))
    x = ou_run(rng, n, dt, tau, mix, 1.0, 300)
    est_a, est_w, inc = [], [], []
    for c in range(100):
        runs = [x[:, :, 3 * c + r] for r in range(3)]
        parts = [cross_variogram_parts(m, dt, tau, correlation_lags(tau, dt, n)) for m in runs]
        est_w.append(as_correlation(sum(p[0] for p in parts)))
        est_a.append(as_correlation(sum(p[1] for p in parts)))
        inc.append(np.corrcoef(np.vstack([np.diff(m, axis=0) for m in runs]).T))
    np.testing.assert_allclose(np.mean(est_a, axis=0), want, atol=0.15)
    np.testing.assert_allclose(np.mean(est_w, axis=0), np.eye(4), atol=0.1)
    iu = np.triu_indices(4, 1)
    assert abs(np.mean(inc, axis=0)[0, 3] - want[0, 3]) > 0.5
    rms_new = np.sqrt(np.mean([(e - want)[iu] ** 2 for e in est_a]))
    rms_inc = np.sqrt(np.mean([(e - want)[iu] ** 2 for e in inc]))
    assert rms_new < rms_inc, (rms_new, rms_inc)


def test_a_heating_and_cooling_curve_beside_the_noise_is_not_read_as_noise() -> None:
    """A gap left in a residual: a run heating for half its length at the thermal time
    constant (five hours) and then cooling, 10–30 µm, or a fast rise and a slow fall of that
    size, beside white noise of 1.3 µm and a pose error of 1.5 µm correlated over 20 min, 90
    visits ten minutes apart. The floor's mean over 60 series is within 10 % of the world's
    √(1.3² + 1.5²), as it is without a curve. (The variogram fitted without detrending, every
    lag weighted alike, read these about 1.24 times the world's.)"""
    rng = np.random.default_rng(20261203)
    n, dt, tau_th = 90, 600.0, 5 * 3600.0
    t = np.arange(n) * dt
    truth = float(np.hypot(1.3, 1.5))
    phi = np.exp(-dt / 1200.0)
    half = t[-1] / 2
    shapes = {
        "none": lambda t: 0.0 * t,
        "heat and cool": lambda t: np.where(
            t < half,
            1 - np.exp(-t / tau_th),
            (1 - np.exp(-half / tau_th)) * np.exp(-(t - half) / tau_th),
        ),
        "fast rise, slow fall": lambda t: (
            (1 - np.exp(-t / (tau_th / 4))) - 0.7 * (1 - np.exp(-t / (2 * tau_th)))
        ),
    }
    got = {}
    for name, shape in shapes.items():
        cols = []
        for _ in range(60):
            z = rng.standard_normal(n)
            ar = np.empty(n)
            ar[0] = z[0]
            for i in range(1, n):
                ar[i] = phi * ar[i - 1] + np.sqrt(1 - phi * phi) * z[i]
            cols.append(1.3 * rng.standard_normal(n) + 1.5 * ar + rng.uniform(10, 30) * shape(t))
        est = series_noise_many(np.column_stack(cols), t, tau_th / SCALE_SEPARATION)
        got[name] = float(np.mean(np.hypot(est[:, 0], est[:, 1]))) / truth
    assert all(abs(v - 1.0) < 0.1 for v in got.values()), got
