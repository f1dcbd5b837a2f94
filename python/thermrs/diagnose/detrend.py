"""The detrended noise model's design: what white noise and an exponentially correlated pose
error become once a series is detrended by a local quadratic over the thermal time scale.

The noise floor (:mod:`.floor`) fits a variogram to each residual series after detrending it
by ``I − S``, S the local quadratic regression smoother with a Gaussian kernel. Its model's
columns are the semivariograms, at the lags fitted, of a unit white part and of a unit
exponential part (one per correlation time τ tried) once detrended: with covariance Σ, the
detrended series has covariance M = (I − S) Σ (I − S)ᵀ, and its mean semivariogram at lag k
is ½ · mean over t of M[t+k, t+k] + M[t, t] − 2 M[t+k, t] (exact for any smoother: a variogram
is linear in the covariance).

Computed densely that is n³ per τ. S varies over the thermal time scale, so it is of low
numerical rank (a Gaussian kernel over ±1 h on a 15-h run: rank ≈ 50 of 900 to 10⁻¹² of its
norm): with S = U Vᵀ (a randomized range finder, checked against S itself) M is
Σ − U (Vᵀ Σ) − (Σ V) Uᵀ + U (Vᵀ Σ V) Uᵀ, Vᵀ Σ is an exponential filter run forwards and
backwards along the visits (O(n·r) per τ), and the lagged sums are cross-correlations
(FFT). The result is the dense one to rounding; where S is not of low rank (a smoother
narrow against the run) the dense products are used.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from scipy import fft as sp_fft

__all__ = ["detrended_design"]

FloatArray = npt.NDArray[np.float64]

#: The low-rank factor of S must reproduce it to this share of its Frobenius norm.
RANK_TOLERANCE = 1e-11

_DESIGNS: dict[tuple[bytes, bytes, bytes, float], tuple[FloatArray, FloatArray, FloatArray]] = {}
_DESIGNS_KEPT = 64


def detrender(t: FloatArray, bandwidth_s: float) -> FloatArray:
    """I − S: S the local quadratic regression smoother with a Gaussian kernel of σ
    ``bandwidth_s`` at the times ``t`` (n × n). Row i of S is w_ij (c0_i + c1_i d_ij +
    c2_i d_ij²), d_ij = (t_j − t_i)/σ, w_ij = e^(−d_ij²/2), (c0, c1, c2) the first row of the
    inverse of the kernel-weighted moments of (1, d, d²)."""
    d = (t[None, :] - t[:, None]) / bandwidth_s
    w = np.exp(-0.5 * d * d)
    wd = w * d
    wd2 = wd * d
    wd3 = wd2 * d
    m = [w.sum(1), wd.sum(1), wd2.sum(1), wd3.sum(1), (wd3 * d).sum(1)]
    g = np.stack([np.stack([m[i + j] for j in range(3)], axis=1) for i in range(3)], axis=1)
    c = np.linalg.solve(g, np.broadcast_to(np.eye(3)[0], (len(t), 3))[:, :, None])[:, :, 0]
    out: FloatArray = np.eye(len(t)) - (c[:, 0:1] * w + c[:, 1:2] * wd + c[:, 2:3] * wd2)
    return out


def band_semivariogram(b: FloatArray, a: FloatArray, lags: npt.NDArray[np.intp]) -> FloatArray:
    """The mean semivariogram at ``lags`` of a series with covariance B·Aᵀ (B = A·Σ), dense."""
    dg = np.einsum("ij,ij->i", b, a)
    out = np.empty(len(lags))
    for i, k in enumerate(lags):
        off = np.einsum("ij,ij->i", b[k:], a[:-k])  # (B·Aᵀ)[t + k, t]
        out[i] = 0.5 * np.mean(dg[k:] + dg[:-k] - 2.0 * off)
    return out


def _dense(
    t: FloatArray, a: FloatArray, lags: npt.NDArray[np.intp], taus: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """The white and correlated columns by the dense products (the definition; n³ per τ)."""
    white = band_semivariogram(a, a, lags)
    corr = np.zeros((len(taus), len(lags)))
    dist = np.abs(t[:, None] - t[None, :])
    for i, tau in enumerate(taus):
        if tau > 0:
            corr[i] = band_semivariogram(a @ np.exp(-dist / tau), a, lags)
    return white, corr


def _low_rank(s: FloatArray, rng: np.random.Generator) -> tuple[FloatArray, FloatArray] | None:
    """S ≈ U Vᵀ (U orthonormal) to :data:`RANK_TOLERANCE` of its norm, or None if that
    takes a rank above a quarter of its size."""
    n = s.shape[0]
    norm = float(np.linalg.norm(s))
    r = 64
    while r <= n // 4:
        q, _ = np.linalg.qr(s @ rng.standard_normal((n, r)))
        vt = q.T @ s
        if np.linalg.norm(s - q @ vt) <= RANK_TOLERANCE * norm:
            return q, vt.T
        r *= 2
    return None


def _exp_filter(x: FloatArray, t: FloatArray, taus: FloatArray) -> FloatArray:
    """Σ_τ x for every τ: y_i = Σ_j e^(−|t_i − t_j|/τ) x_j along the last axis of ``x``
    (… × n, ``t`` sorted), by one pass forwards and one backwards: τ × … × n."""
    rho = np.exp(-np.diff(t)[None, :] / taus[:, None])  # τ × (n − 1)
    shape = (len(taus), *x.shape)
    f = np.empty(shape)
    b = np.empty(shape)
    f[..., 0] = x[..., 0]
    b[..., -1] = x[..., -1]
    extra = (slice(None),) + (None,) * (x.ndim - 1)
    n = x.shape[-1]
    for i in range(1, n):
        f[..., i] = x[..., i] + rho[:, i - 1][extra] * f[..., i - 1]
    for i in range(n - 2, -1, -1):
        b[..., i] = x[..., i] + rho[:, i][extra] * b[..., i + 1]
    out: FloatArray = f + b - x[None]
    return out


def _low_rank_design(
    t: FloatArray,
    u: FloatArray,
    v: FloatArray,
    lags: npt.NDArray[np.intp],
    taus: FloatArray,
) -> tuple[FloatArray, FloatArray]:
    """The white and correlated columns from S = U Vᵀ (module docs)."""
    n = len(t)
    counts = n - lags
    size = sp_fft.next_fast_len(n + int(lags[-1]) + 1, real=True)
    fu = sp_fft.rfft(u.T, size, axis=-1)  # r × f

    def semivariogram(
        diag: FloatArray, band_sigma: FloatArray, wt: FloatArray, h: FloatArray
    ) -> FloatArray:
        # diag: … × n, M[t, t]; band_sigma: … × lags, Σ_t Σ[t + k, t]; wt = Σ V and
        # h = U (Vᵀ Σ V)ᵀ, each … × r × n. The lagged sums Σ_t Σ_m x[m, t + k] y[m, t] of
        # U·(Σ V), (Σ V)·U and U·h at once: a cross-correlation, x̂ conj(ŷ) summed over m.
        cum = np.cumsum(diag, axis=-1)
        upper = cum[..., -1:] - np.take(cum, lags - 1, axis=-1)  # Σ_{t ≥ k} diag
        lower = np.take(cum, n - lags - 1, axis=-1)  # Σ_{t < n − k} diag
        fw = sp_fft.rfft(wt, size, axis=-1)
        fh = sp_fft.rfft(h, size, axis=-1)
        spec = np.sum(fu * np.conj(fw) + fw * np.conj(fu) - fu * np.conj(fh), axis=-2)
        band = band_sigma - sp_fft.irfft(spec, size, axis=-1)[..., lags]
        out: FloatArray = 0.5 * (upper + lower - 2.0 * band) / counts
        return out

    # White: Σ = I.
    h = (u @ (v.T @ v).T).T
    diag = 1.0 - 2.0 * np.einsum("tm,tm->t", u, v) + np.einsum("mt,tm->t", h, u)
    white = semivariogram(diag, np.zeros(len(lags)), np.ascontiguousarray(v.T), h)
    corr = np.zeros((len(taus), len(lags)))
    pos = taus > 0
    if np.any(pos):
        tp = taus[pos]
        wts = _exp_filter(np.ascontiguousarray(v.T), t, tp)  # τ × r × n: (Σ_τ V)ᵀ
        cores = wts @ v  # τ × r × r: Vᵀ Σ V
        hs = cores @ u.T  # τ × r × n: (U (Vᵀ Σ V)ᵀ)ᵀ
        diags = 1.0 - 2.0 * np.einsum("tm,kmt->kt", u, wts) + np.einsum("tm,kmt->kt", u, hs)
        gaps = [t[k:] - t[:-k] for k in lags]
        band_sigma = np.array([[float(np.sum(np.exp(-g / tau))) for g in gaps] for tau in tp])
        corr[pos] = semivariogram(diags, band_sigma, wts, hs)
    return white, corr


def detrended_design(
    t: FloatArray, lags: npt.NDArray[np.intp], taus: FloatArray, bandwidth_s: float
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """I − S (:func:`detrender`), and the semivariogram at ``lags`` that a unit white part
    and a unit correlated part (each τ of ``taus``; τ = 0 a row of zeros) have once
    detrended: the noise model's columns (module docs). Kept per sampling up to its start
    (the replicates of a series, and the series of runs sampled alike, share it)."""
    t = np.asarray(t, dtype=np.float64)
    t = t - t[0]  # everything here depends on the times' differences only
    key = (t.tobytes(), lags.tobytes(), taus.tobytes(), bandwidth_s)
    got = _DESIGNS.get(key)
    if got is not None:
        return got
    a = detrender(t, bandwidth_s)
    factor = _low_rank(np.eye(len(t)) - a, np.random.default_rng(0))
    if factor is None:
        white, corr = _dense(t, a, lags, taus)
    else:
        white, corr = _low_rank_design(t, factor[0], factor[1], lags, taus)
    if len(_DESIGNS) >= _DESIGNS_KEPT:
        _DESIGNS.pop(next(iter(_DESIGNS)))
    _DESIGNS[key] = (a, white, corr)
    return a, white, corr
