"""Least squares with honest intervals for autocorrelated measurement series.

Drift measurements come as *series*: one per (run, camera), a visit every cycle, each visit a
*unit* of one or more rows (its u and v positions). Their errors are not independent: pose
repeatability, slow drifts the model does not carry and centroid bias move together from one
visit to the next (autocorrelation within a series) and between u and v within a visit
(correlation within a unit). An interval computed as if every row were independent is too
narrow by the square root of the variance inflation, often 2–5×.

This module gives the pieces to do better:

:func:`lstsq_qr`
    Weighted linear least squares by QR on unit-norm columns (never the normal matrix, never a
    pseudo-inverse with a default cutoff: columns of very different scale, say a sensitivity
    of 10⁶ µm per unit α beside unit offset columns, keep their full precision), returning the
    coefficients and their covariance: ``"iid"`` (classical s²·(XᵀWX)⁻¹) or ``"hac"``: a
    Newey–West sandwich over the units of each series, summed over series, prewhitened by an
    AR(1) per coefficient (Andrews & Monahan 1992) with a data-chosen Bartlett bandwidth
    (:func:`andrews_bandwidth`), and a Student-t interval whose degrees of freedom follow the
    effective sample size (:meth:`LeastSquares.interval`).
:func:`effective_sample_size`
    Effective number of independent samples of an autocorrelated series (AR(1) formula
    N·(1−ρ₁)/(1+ρ₁), or Geyer's initial positive sequence over all lags).
:func:`moving_block_indices`
    A moving-block bootstrap resample of the units of each series (Künsch 1989).

Why not GLS: feasible GLS with an AR(1) fitted on the residuals is what one reaches for
first, but with strongly autocorrelated errors (ρ ≈ 0.8) and a few hundred visits its
estimate moves with the error of ρ̂ (on synthetic visit series its spread was 17 % wider than
GLS with the true ρ, while its standard error did not grow), so its interval under-covers.
Least squares with smooth regressors (warm-up curves) is nearly as efficient as GLS
(Grenander 1954), and its spread does not depend on ρ̂; only its standard error does.

Every function takes plain numpy arrays; row labels (``series``, ``units``) are any hashable
values in an array, ``order`` any sortable number (a time stamp).
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from typing import Literal

import numpy as np
import numpy.typing as npt
import scipy.linalg

from thermrs.memo import ContentCache, content_key

__all__ = [
    "LeastSquares",
    "andrews_bandwidth",
    "ar1_coefficient",
    "ar1_variance_inflation",
    "effective_sample_size",
    "loess2",
    "lstsq_qr",
    "moving_block_indices",
]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]

#: Largest |ρ| used when whitening or choosing a bandwidth (keeps both finite near a unit root).
RHO_CLIP = 0.97


@dataclass(frozen=True)
class LeastSquares:
    """A linear least-squares fit and the covariance of its coefficients.

    Attributes
    ----------
    coef
        The coefficients, in the columns' own units.
    cov
        Their covariance matrix (see ``method``).
    residuals
        ``y − X·coef`` per row, unweighted (the caller's rows).
    dof
        Residual degrees of freedom: rows − coefficients.
    sigma2
        Weighted residual variance per degree of freedom.
    method
        How ``cov`` was obtained, in words.
    bandwidth
        Bartlett bandwidth in units (0 for ``"iid"``).
    n_eff
        Effective number of independent units behind the first coefficient: for ``"iid"`` the
        number of units; for ``"hac"`` the number of units times var_iid/var_hac (at most
        the number of units).
    t_dof
        Degrees of freedom of the Student-t interval: ``dof`` for ``"iid"``; for a
        prewhitened ``"hac"``, a Satterthwaite-style count of what the standard error rests
        on: per series (Σψ²)²/Σψ⁴ over the whitened influences ψ of the first coefficient,
        times (1−φ), combined over the series by Satterthwaite's rule, at most ``dof``.
        The (1−φ) is calibrated, not derived: on synthetic visit series (two series of 150
        visits, AR(1) ρ 0, 0.7, 0.9, u–v correlated; 400 trials each) the ν = 1/(2·var log SE)
        observed was 30, 9 and 3, this count gave 34, 10 and 3.1, and the interval covered
        in 95.5 %, 95.8 % and 97.0 % of trials.
    ar1
        Per coefficient, the AR(1) coefficient its influence series were prewhitened with
        (each series its own; here their mean weighted by each series' share of the first
        coefficient's variance; zeros without prewhitening).
    """

    coef: FloatArray
    cov: FloatArray
    residuals: FloatArray
    dof: int
    sigma2: float
    method: str
    bandwidth: int
    n_eff: float
    t_dof: float
    ar1: FloatArray

    def stderr(self) -> FloatArray:
        """Standard errors of the coefficients."""
        return np.sqrt(np.diag(self.cov))

    def interval(self, j: int = 0, *, level: float = 0.95) -> tuple[float, float]:
        """Two-sided Student-t interval (``t_dof`` degrees of freedom) of coefficient ``j``."""
        import scipy.stats

        half = float(scipy.stats.t.ppf(0.5 + level / 2, self.t_dof)) * float(self.stderr()[j])
        c = float(self.coef[j])
        return (c - half, c + half)


def _labels(a: npt.ArrayLike | None, n: int, what: str) -> IntArray:
    """Integer codes 0..k-1 of a label array (all zeros when None)."""
    if a is None:
        return np.zeros(n, dtype=np.intp)
    arr = np.asarray(a)
    if arr.shape != (n,):
        raise ValueError(f"{what} has shape {arr.shape}, expected ({n},)")
    _, codes = np.unique(arr.astype(str) if arr.dtype == object else arr, return_inverse=True)
    return codes.astype(np.intp)


def _unit_layout(
    n: int,
    series: npt.ArrayLike | None,
    units: npt.ArrayLike | None,
    order: npt.ArrayLike | None,
) -> tuple[IntArray, list[IntArray]]:
    """Per row its unit code; per series the unit codes in time order."""
    s = _labels(series, n, "series")
    u = _labels(units, n, "units") if units is not None else np.arange(n, dtype=np.intp)
    t = np.arange(n, dtype=np.float64) if order is None else np.asarray(order, dtype=np.float64)
    if t.shape != (n,):
        raise ValueError(f"order has shape {t.shape}, expected ({n},)")
    # A unit is (series, unit label): the same label in two series is two units.
    pair = s.astype(np.int64) * (int(u.max()) + 1 if n else 1) + u
    _, unit = np.unique(pair, return_inverse=True)
    unit = unit.astype(np.intp)
    k = int(unit.max()) + 1 if n else 0
    t_unit = np.full(k, np.inf)
    np.minimum.at(t_unit, unit, t)
    s_unit = np.zeros(k, dtype=np.intp)
    s_unit[unit] = s
    chains = []
    for g in np.unique(s_unit):
        members = np.flatnonzero(s_unit == g)
        chains.append(members[np.argsort(t_unit[members], kind="stable")])
    return unit, chains


def ar1_coefficient(x: npt.ArrayLike) -> float:
    """Lag-1 autocorrelation of a series about its mean, Σ(xₜ−x̄)(xₜ₋₁−x̄)/Σ(xₜ−x̄)².

    0 for series shorter than 3 or without variance.
    """
    a = np.asarray(x, dtype=np.float64)
    a = a[np.isfinite(a)]
    if len(a) < 3:
        return 0.0
    a = a - a.mean()
    den = float(a @ a)
    return float(a[1:] @ a[:-1]) / den if den > 0 else 0.0


def ar1_variance_inflation(x: npt.ArrayLike) -> float:
    """How much a series' autocorrelation inflates the variance of a smooth fit through it:
    (1+ρ)/(1−ρ) with ρ its lag-1 autocorrelation plus Kendall's (1954) bias (1+3ρ)/N, at
    least 1 (ρ at most 0.97). N/N_eff of an AR(1) series.
    """
    a = np.asarray(x, dtype=np.float64)
    a = a[np.isfinite(a)]
    n = len(a)
    if n < 3:
        return 1.0
    r = ar1_coefficient(a)
    r = min(r + (1 + 3 * r) / n, RHO_CLIP)
    return max(1.0, (1 + r) / (1 - r))


def effective_sample_size(x: npt.ArrayLike, *, method: Literal["ar1", "geyer"] = "geyer") -> float:
    """Effective number of independent samples of an autocorrelated series.

    The N samples of a stationary series with autocorrelations ρₖ estimate its mean with the
    variance of N_eff independent ones, N_eff = N / (1 + 2·Σₖ ρₖ).

    Parameters
    ----------
    x
        The series, in time order (non-finite values are dropped).
    method
        ``"ar1"``: N·(1−ρ₁)/(1+ρ₁), exact for an AR(1) series; ``"geyer"`` (default): Geyer's
        (1992) initial positive sequence: the sum over lags of the autocorrelations, truncated
        where the sum of a pair of consecutive lags first turns negative; it makes no
        assumption on the shape of the autocorrelation.

    Returns
    -------
    float
        N_eff, within [1, N] (N for N < 3).
    """
    a = np.asarray(x, dtype=np.float64)
    a = a[np.isfinite(a)]
    n = len(a)
    if n < 3:
        return float(n)
    if method == "ar1":
        r = ar1_coefficient(a)
        ess = n * (1 - r) / (1 + r) if r > -1 else float(n)
    elif method == "geyer":
        d = a - a.mean()
        var = float(d @ d) / n
        if var <= 0:
            return float(n)
        m = 1 << int(np.ceil(np.log2(2 * n)))
        f = np.fft.rfft(d, m)
        acov = np.fft.irfft(f * np.conj(f), m)[:n] / n
        rho = acov / var
        # Γₘ = ρ₂ₘ + ρ₂ₘ₊₁; sum while positive, made monotone (Geyer's initial monotone seq.).
        pairs = rho[: 2 * ((n - 1) // 2)].reshape(-1, 2).sum(axis=1) if n > 2 else rho[:0]
        total = 0.0
        prev = np.inf
        for g in pairs:
            if g <= 0:
                break
            g = min(float(g), prev)
            total += g
            prev = g
        tau = -1.0 + 2.0 * total  # 1 + 2Σ_{k≥1} ρₖ = −ρ₀ + 2Σₘ Γₘ
        ess = n / tau if tau > 0 else float(n)
    else:
        raise ValueError(f"method must be 'ar1' or 'geyer', got {method!r}")
    return float(min(max(ess, 1.0), n))


def andrews_bandwidth(scores: FloatArray, chains: list[IntArray]) -> int:
    """Data-chosen Bartlett bandwidth (units) for a Newey–West covariance.

    Andrews' (1991) AR(1) plug-in: each score component's AR(1) coefficient ρⱼ and innovation
    variance σⱼ², pooled over the series, give α(1) = Σ 4ρⱼ²σⱼ⁴/((1−ρⱼ)⁶(1+ρⱼ)²) /
    Σ σⱼ⁴/(1−ρⱼ)⁴ and the bandwidth 1.1447·(α(1)·T)^{1/3}, T the mean series length.

    Parameters
    ----------
    scores
        Per unit, the score vector (units × coefficients).
    chains
        Per series, its units' row indices into ``scores`` in time order.
    """
    lengths = [len(c) for c in chains]
    t_mean = float(np.mean(lengths)) if lengths else 0.0
    if t_mean < 3:
        return 0
    num = den = 0.0
    for j in range(scores.shape[1]):
        xy = [(scores[c[1:], j], scores[c[:-1], j]) for c in chains if len(c) >= 3]
        if not xy:
            continue
        cur = np.concatenate([a for a, _ in xy])
        lag = np.concatenate([b for _, b in xy])
        sxx = float(lag @ lag)
        if sxx <= 0:
            continue
        rho = float(np.clip((cur @ lag) / sxx, -RHO_CLIP, RHO_CLIP))
        s2 = float(np.mean((cur - rho * lag) ** 2))
        num += 4 * rho**2 * s2**2 / ((1 - rho) ** 6 * (1 + rho) ** 2)
        den += s2**2 / (1 - rho) ** 4
    if den <= 0:
        return 0
    bw = 1.1447 * (num / den * t_mean) ** (1 / 3)
    return int(min(np.floor(bw), max(lengths) - 1))


def unit_qr(x: FloatArray, *, rtol: float) -> tuple[FloatArray, FloatArray, FloatArray] | None:
    """QR of ``x``'s columns scaled to unit norm: (q, r, the norms); None where a column is
    zero or not finite, or where the columns are dependent (a diagonal of r below ``rtol``
    times its largest)."""
    norms = np.linalg.norm(x, axis=0)
    if np.any(norms == 0) or not np.all(np.isfinite(norms)):
        return None
    q, r = np.linalg.qr(x / norms)
    dg = np.abs(np.diag(r))
    if dg.min() < rtol * dg.max():
        return None
    return np.asarray(q, dtype=np.float64), np.asarray(r, dtype=np.float64), norms


def _qr_solve(xw: FloatArray, yw: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Coefficients and (XᵀX)⁻¹ by QR on unit-norm columns; raises on a rank-deficient X."""
    norms = np.linalg.norm(xw, axis=0)
    zero = np.flatnonzero(norms == 0)
    if len(zero):
        raise ValueError(f"design columns {zero.tolist()} are all zero")
    xs = xw / norms
    q, r = scipy.linalg.qr(xs, mode="economic")
    d = np.abs(np.diag(r))
    tol = max(xs.shape) * np.finfo(np.float64).eps * 10
    bad = np.flatnonzero(d <= tol * max(float(d.max()), 1.0))
    if len(bad):
        raise ValueError(f"design is rank deficient: column(s) {bad.tolist()} depend on the others")
    coef_s = scipy.linalg.solve_triangular(r, q.T @ yw)
    rinv = scipy.linalg.solve_triangular(r, np.eye(r.shape[0]))
    bread_s = rinv @ rinv.T
    return coef_s / norms, bread_s / np.outer(norms, norms)


def _hac_meat(scores: FloatArray, chains: list[IntArray], bandwidth: int) -> FloatArray:
    """Σ over series of Σ_{|l|≤L} (1 − |l|/(L+1))·Γₗ of the unit scores."""
    p = scores.shape[1]
    meat = np.zeros((p, p))
    for c in chains:
        g = scores[c]
        meat += g.T @ g
        for lag in range(1, min(bandwidth, len(c) - 1) + 1):
            w = 1.0 - lag / (bandwidth + 1.0)
            gamma = g[lag:].T @ g[:-lag]
            meat += w * (gamma + gamma.T)
    return meat


def lstsq_qr(
    x: npt.ArrayLike,
    y: npt.ArrayLike,
    weights: npt.ArrayLike | None = None,
    *,
    covariance: Literal["iid", "hac"] = "iid",
    series: npt.ArrayLike | None = None,
    units: npt.ArrayLike | None = None,
    order: npt.ArrayLike | None = None,
    bandwidth: int | None = None,
    prewhiten: bool = True,
) -> LeastSquares:
    """Weighted linear least squares by QR on unit-norm columns, with an honest covariance.

    Minimises Σ wᵢ·(yᵢ − xᵢ·β)². The columns of √w·X are scaled to unit norm before a QR
    decomposition (no normal matrix, no pseudo-inverse cutoff), so a design mixing columns
    of scale 10⁷ and 1 keeps every singular direction; a rank-deficient design raises.

    Parameters
    ----------
    x, y
        Design (rows × coefficients) and observations; every value must be finite.
    weights
        Per-row weights (inverse variances); default all 1.
    covariance
        ``"iid"``: s²·(XᵀWX)⁻¹, rows independent. ``"hac"``: the Newey–West sandwich
        Σ over ``series`` of the Bartlett-weighted autocovariances of the units' influence
        vectors (XᵀWX)⁻¹·Σ_rows √wᵢxᵢ·√wᵢeᵢ (summed over a unit's rows, so rows of one unit
        may be correlated in any way), times n/(n−p).
    series, units, order
        Per row: its series label, its unit label (rows sharing one within a series form
        one unit; default every row its own unit) and its time (units are ordered within a
        series by their earliest row; default row order). Used by ``"hac"`` only.
    bandwidth
        Bartlett bandwidth in units; default :func:`andrews_bandwidth` on the (prewhitened)
        influence series.
    prewhiten
        ``"hac"`` only: prewhiten each coefficient's influence series by an AR(1) of its own
        per series (Kendall bias-corrected, φ ≥ 0), apply Newey–West to what is left, and
        recolour by 1/(1−φ) (Andrews & Monahan 1992); the first coefficient's variance is
        never below the ``"iid"`` one (the whole matrix scaled up to it, ``t_dof`` = ``dof``,
        ``method`` says so). Without it, Newey–West alone
        under-covers badly when the errors are strongly autocorrelated (its bandwidth would
        need to span the whole correlation length).

    Returns
    -------
    LeastSquares
        The fit; :meth:`LeastSquares.interval` gives the interval.
    """
    xa, ya, w = _checked(x, y, weights)
    n, p = xa.shape
    dof = n - p
    sw = np.sqrt(w)
    xw, yw = xa * sw[:, None], ya * sw
    coef, bread = _qr_solve(xw, yw)
    ew = yw - xw @ coef
    sigma2 = float(ew @ ew) / dof
    cov_iid = sigma2 * bread
    unit, chains = _unit_layout(n, series, units, order)
    n_units = int(unit.max()) + 1
    if covariance == "iid":
        return LeastSquares(
            coef,
            cov_iid,
            ya - xa @ coef,
            dof,
            sigma2,
            "iid",
            0,
            float(n_units),
            float(dof),
            np.zeros(p),
        )
    if covariance != "hac":
        raise ValueError(f"covariance must be 'iid' or 'hac', got {covariance!r}")
    cov, bw, n_eff, t_dof, phi, floor = _hac_covariance(
        xw, ew, bread, unit, chains, cov_iid, bandwidth=bandwidth, prewhiten=prewhiten
    )
    how = "AR(1)-prewhitened " if prewhiten else ""
    return LeastSquares(
        coef,
        cov,
        ya - xa @ coef,
        dof,
        sigma2,
        f"{how}Newey–West (Bartlett kernel, data-chosen bandwidth {bw} units) over "
        f"{len(chains)} series of {n_units} units"
        + (", at its floor: the iid covariance" if floor else ""),
        bw,
        n_eff,
        t_dof,
        phi,
    )


def _hac_covariance(
    xw: FloatArray,
    ew: FloatArray,
    bread: FloatArray,
    unit: IntArray,
    chains: list[IntArray],
    cov_iid: FloatArray,
    *,
    bandwidth: int | None,
    prewhiten: bool,
) -> tuple[FloatArray, int, float, float, FloatArray, bool]:
    """The ``"hac"`` covariance of :func:`lstsq_qr` from the weighted design and residuals:
    ``(cov, bandwidth, n_eff, t_dof, phi, at_floor)``."""
    n, p = xw.shape
    dof = n - p
    n_units = int(unit.max()) + 1
    phis, white = _influences(xw, ew, bread, unit, n_units, chains, prewhiten=prewhiten)
    bw = andrews_bandwidth(white, chains) if bandwidth is None else int(bandwidth)
    if bw < 0:
        raise ValueError(f"bandwidth must be ≥ 0, got {bw}")
    cov, v0, nu = _series_shares(white, chains, phis, bw)
    cov = (cov + cov.T) / 2 * (n / dof)
    ratio = cov_iid[0, 0] / cov[0, 0] if cov[0, 0] > 0 else 1.0
    n_eff = float(np.clip(n_units * ratio, 1.0, n_units))
    t_dof = float(dof)
    if prewhiten and v0.sum() > 0:
        t_dof = float(min(dof, max(v0.sum() ** 2 / np.sum(v0**2 / nu), 1.0)))
    floor = prewhiten and ratio > 1.0
    if floor:
        # Never narrower than the classical interval: where the visits show no
        # autocorrelation the sandwich only adds its own noise (on simulated recordings with
        # independent visit errors it came out 17 % narrower than the spread of α̂).
        cov = cov * ratio
        t_dof = float(dof)
    share = v0 / v0.sum() if v0.sum() > 0 else np.full(len(chains), 1 / max(len(chains), 1))
    phi: FloatArray = share @ phis
    return cov, bw, n_eff, t_dof, phi, floor


def _checked(
    x: npt.ArrayLike, y: npt.ArrayLike, weights: npt.ArrayLike | None
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """:func:`lstsq_qr`'s inputs as float arrays, checked (shapes, finite values, positive
    weights, at least one degree of freedom).

    Raises
    ------
    ValueError
        Naming what is wrong.
    """
    xa = np.asarray(x, dtype=np.float64)
    ya = np.asarray(y, dtype=np.float64)
    if xa.ndim != 2 or ya.shape != (xa.shape[0],):
        raise ValueError(f"x has shape {xa.shape} and y {ya.shape}: expected (n, p) and (n,)")
    n, p = xa.shape
    w = np.ones(n) if weights is None else np.asarray(weights, dtype=np.float64)
    if w.shape != (n,) or np.any(~np.isfinite(w)) or np.any(w <= 0):
        raise ValueError("weights must be one positive finite value per row")
    if not (np.all(np.isfinite(xa)) and np.all(np.isfinite(ya))):
        raise ValueError("x and y must be finite")
    if n - p < 1:
        raise ValueError(f"{n} rows for {p} coefficients: no degree of freedom left")
    return xa, ya, w


def _influences(
    xw: FloatArray,
    ew: FloatArray,
    bread: FloatArray,
    unit: IntArray,
    n_units: int,
    chains: list[IntArray],
    *,
    prewhiten: bool,
) -> tuple[FloatArray, FloatArray]:
    """Each unit's influence on the coefficients, (XᵀWX)⁻¹ Σ_rows √wᵢxᵢ·√wᵢeᵢ, and per series
    and coefficient its AR(1) φ (≥ 0; zeros without ``prewhiten``): ``(phis, whitened)``."""
    p = xw.shape[1]
    scores = np.zeros((n_units, p))
    np.add.at(scores, unit, xw * ew[:, None])
    infl = scores @ bread
    # Prewhitening: each series its own AR(1) per coefficient (series of one rig may differ:
    # a pooled φ understates the long-run variance of the most correlated one).
    phis = np.zeros((len(chains), p))
    white = infl.copy()
    if prewhiten:
        for i, c in enumerate(chains):
            # A negative φ would shrink the variance below the independent-visit value; the
            # interval never claims that (on simulated recordings with independent visit
            # errors φ̂ came out near −0.1 and the interval covered in 8 of 10 runs).
            phis[i] = np.maximum(_pooled_ar1(infl, [c], bias_correction=True), 0.0)
            white[c[1:]] = infl[c[1:]] - phis[i] * infl[c[:-1]]
    return phis, white


def _series_shares(
    white: FloatArray, chains: list[IntArray], phis: FloatArray, bw: int
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """The recoloured Newey–West sum over series, and per series its share of the first
    coefficient's variance and the degrees of freedom behind it: ``(cov, v0, nu)``."""
    p = white.shape[1]
    cov = np.zeros((p, p))
    v0, nu = np.zeros(len(chains)), np.zeros(len(chains))
    for i, c in enumerate(chains):
        recolor = 1.0 / (1.0 - phis[i])
        part = _hac_meat(white, [c], bw) * np.outer(recolor, recolor)
        cov += part
        # Degrees of freedom of this series' share (Satterthwaite-style): a sum of squared
        # influences carries (Σψ²)²/Σψ⁴ "samples" (fewer the heavier the tails of ψ),
        # thinned by (1−φ) by the estimated AR(1) recolouring (see LeastSquares.t_dof).
        psi2 = white[c, 0] ** 2
        n4 = float(psi2.sum() ** 2 / np.sum(psi2**2)) if np.sum(psi2**2) > 0 else len(c)
        v0[i], nu[i] = part[0, 0], max(n4 * (1 - phis[i, 0]), 1.0)
    return cov, v0, nu


def _pooled_ar1(
    z: FloatArray, chains: list[IntArray], *, bias_correction: bool = False
) -> FloatArray:
    """Per column of ``z``: the AR(1) coefficient pooled over the chains, clipped; with
    ``bias_correction`` plus Kendall's (1954) first-order bias (1 + 3φ)/T of a series of T
    (T the mean chain length)."""
    num = np.zeros(z.shape[1])
    den = np.zeros(z.shape[1])
    for c in chains:
        if len(c) < 2:
            continue
        num += np.sum(z[c[1:]] * z[c[:-1]], axis=0)
        den += np.sum(z[c[:-1]] ** 2, axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        phi = np.where(den > 0, num / den, 0.0)
    if bias_correction:
        t_mean = float(np.mean([len(c) for c in chains])) if chains else 0.0
        if t_mean >= 3:
            phi = phi + (1 + 3 * phi) / t_mean
    return np.clip(phi, -RHO_CLIP, RHO_CLIP)


def moving_block_indices(
    groups: npt.ArrayLike,
    *,
    block_length: int,
    rng: np.random.Generator,
    order: npt.ArrayLike | None = None,
) -> Iterator[IntArray]:
    """Endless moving-block bootstrap resamples, block by block within each group.

    For each group (a series of units in ``order``), blocks of ``block_length`` consecutive
    units start at uniformly drawn positions (any of the N−b+1 starts) and are laid end to
    end until the group's length is reached (the last block cut short); groups keep their
    sizes. Each draw yields the indices into ``groups`` of one resample.

    Parameters
    ----------
    groups
        Per unit, its group (series) label.
    block_length
        Units per block (≥ 1; at least the span of the autocorrelation).
    rng
        The random generator.
    order
        Per unit, its time; default the array order.

    Yields
    ------
    numpy.ndarray
        Indices (length = number of units) of one resample.
    """
    if block_length < 1:
        raise ValueError(f"block_length must be ≥ 1, got {block_length}")
    g = np.asarray(groups)
    n = len(g)
    t = np.arange(n, dtype=np.float64) if order is None else np.asarray(order, dtype=np.float64)
    codes = _labels(g, n, "groups")
    chains = []
    for k in np.unique(codes):
        members = np.flatnonzero(codes == k)
        chains.append(members[np.argsort(t[members], kind="stable")])
    while True:
        out = []
        for c in chains:
            m = len(c)
            b = min(block_length, m)
            k = -(-m // b)
            starts = rng.integers(0, m - b + 1, size=k)
            idx = (starts[:, None] + np.arange(b)[None, :]).ravel()[:m]
            out.append(c[idx])
        yield np.concatenate(out) if out else np.zeros(0, dtype=np.intp)


def loess2(t: np.ndarray, y: np.ndarray, h: float) -> np.ndarray:
    """Local quadratic regression with tricube weights of half-width ``h`` (every sample's
    weighted least squares by QR on its window, all windows at once). ``y``: one series, or
    several sampled at the same times (samples × series): the smoother is linear, its
    weights depend on the times only, and are computed once per times and ``h`` (kept for
    the next call: a diagnosis smooths the same readings at the same widths again)."""
    y = np.asarray(y, dtype=np.float64)
    ok = np.isfinite(y) if y.ndim == 1 else np.all(np.isfinite(y), axis=1)
    if ok.sum() < 5:
        return y
    if y.ndim == 2 and not ok.all():  # each series its own finite samples
        return np.column_stack([loess2(t, y[:, k], h) for k in range(y.shape[1])])
    t = np.asarray(t, dtype=np.float64)
    idx, j, w = _LOESS.get(content_key(t, ok, float(h)), lambda: _loess2_weights(t, ok, h))
    out = y.copy()
    if len(idx):
        yy = y[ok]
        out[idx] = np.einsum("nw,nw...->n...", w, yy[j])
    return out


def _loess2_weights(
    t: np.ndarray, ok: np.ndarray, h: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The local quadratic's weights: per sample it is fitted at (``idx``), the finite
    samples of its window (``j``) and their weights (``w``: its fitted value is Σ w·y)."""
    tt = t[ok]
    lo = np.searchsorted(tt, t - h, side="left")
    hi = np.searchsorted(tt, t + h, side="right")
    idx = np.flatnonzero(ok & (hi - lo >= 5))
    if not len(idx):
        return idx, np.zeros((0, 1), dtype=np.intp), np.zeros((0, 1))
    width = int((hi - lo)[idx].max())
    j = lo[idx, None] + np.arange(width)[None, :]
    inside = j < hi[idx, None]
    j = np.minimum(j, len(tt) - 1)
    x = (tt[j] - t[idx, None]) / h
    ax = np.minimum(np.abs(x), 1.0)
    u = 1.0 - ax * ax * ax
    sw = np.where(inside, u * np.sqrt(u), 0.0)  # tricube weight^1.5 (the rows' scaling)
    # The fitted value at the centre is the intercept: e0ᵀ (XᵀWX)⁻¹ XᵀW y, so each window's
    # weights are W·(c0 + c1·x + c2·x²) with (XᵀWX) c = e0. The columns 1, x, x² on x ∈ [−1, 1]
    # (time over the half-width) are scaled, and the 3 × 3 moment matrices solved at once
    # (a window too short or too lopsided for a quadratic, near-singular, is left as it is).
    w2 = sw * sw  # the rows scaled by the tricube weight: least squares weighted by its square
    x2 = x * x
    w2x, w2x2 = w2 * x, w2 * x2
    p = [w2.sum(1), w2x.sum(1), w2x2.sum(1), (w2x2 * x).sum(1), (w2x2 * x2).sum(1)]
    m = np.stack(
        [np.stack([p[0], p[1], p[2]], -1), np.stack([p[1], p[2], p[3]], -1),
         np.stack([p[2], p[3], p[4]], -1)], -2,
    )  # fmt: skip
    # A QR of the weighted columns would have R₂₂² = det M / det M₁:₂ and R₀₀² = M₀₀: the
    # quadratic is kept where |R₂₂| > 10⁻⁹ |R₀₀|, as a QR would keep it.
    d2 = p[0] * p[2] - p[1] ** 2
    with np.errstate(divide="ignore", invalid="ignore"):
        good = np.linalg.det(m) > 1e-18 * np.abs(d2) * p[0]
    good &= d2 > 0
    e0 = np.zeros((int(good.sum()), 3))
    e0[:, 0] = 1.0
    c = np.linalg.solve(m[good], e0[..., None])[..., 0]
    w = c[:, :1] * w2[good] + c[:, 1:2] * w2x[good] + c[:, 2:3] * w2x2[good]
    w.setflags(write=False)
    return idx[good], j[good], w


#: The local quadratic's weights by times, finite samples and half-width (:func:`loess2`).
_LOESS: ContentCache[tuple[np.ndarray, np.ndarray, np.ndarray]] = ContentCache(64)
