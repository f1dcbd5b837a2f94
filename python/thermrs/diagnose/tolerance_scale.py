"""How far the rig's errors exceed what it states, estimated from the held-out residual.

The null world (:mod:`.tolerances`) adds the rig's tolerance signatures ``N`` (2n × p, one
column a stated standard uncertainty) with standard normal weights. A rig whose real errors
are k times what it states adds ``k·N·w`` instead. Refitting the nominal model is linear, so
on the held-out rows the nominal residual is, with no effect,

    r = k·B·w + e,   B = the held-out residual of N's columns, e = the noise's.

Only the part of ``r`` along B's leading directions carries information on k. With U the
first m left singular vectors of B and ``c = Uᵀr``, ``c ~ N(0, k²·S² + C)``, where S² is B's
singular values squared and C the covariance of ``Uᵀe``, measured on replicates of the
floor's noise model refitted as the data were (:func:`.null.draw_noise`). Whitened by C and
rotated to the generalised eigenvectors of (S², C), the components are independent,
``c̃ᵢ ~ N(0, k²λᵢ + 1)``: k is estimated by maximum likelihood, and its 95 % interval is the
set of k the likelihood-ratio test does not reject at 5 %, calibrated by simulating that
exact model (not by Wilks's χ², which a handful of informative components does not reach);
its one-sided 95 % upper bound is the upper end of the 90 % interval.

The estimate is made under the hypothesis of no effect: an effect whose held-out signature
lies along the tolerances' raises it. It is reported, and the verdict says when its interval
lies above 1; where effects are named it is made with them fitted too (what they absorb of
the tolerances' signatures is then counted, and the estimate holds whether they are real or
not). The test an effect of the robot is named behind does not take it: it holds its level on
any rig erring by up to three times its statement (:mod:`.guard`), since an effect the
library's form fits only in part raises this estimate far above what the rig errs by.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from thermrs.diagnose.family_fit import DesignMatrix
from thermrs.diagnose.floor import NoiseFloor
from thermrs.diagnose.null import Batch, draw_noise

__all__ = ["ToleranceScale", "tolerance_scale"]

FloatArray = npt.NDArray[np.float64]

#: The largest scale considered (a rig erring by more than this many times its statement is
#: reported as "at least" this).
K_MAX = 20.0
#: Directions of the tolerances' held-out signatures kept (the leading ones): the noise
#: covariance along them is measured on :data:`NOISE_DRAWS` replicates, which must be many
#: more than the directions.
MAX_DIRECTIONS = 20
#: Replicates of the noise model for its covariance along those directions.
NOISE_DRAWS = 299
#: Simulations of the likelihood-ratio statistic per scale for the interval.
LR_DRAWS = 400


@dataclass
class ToleranceScale:
    """The estimate of the factor k by which the rig's errors exceed its stated tolerances.

    Attributes
    ----------
    estimate
        Maximum-likelihood k (0 where the data show less than the noise alone would).
    ci95
        The 95 % interval: every k the likelihood-ratio test does not reject at 5 %; its upper
        end is :data:`K_MAX` where the data do not bound it.
    upper95
        The 95 % upper confidence bound: the upper end of the 90 % interval (k above it is
        rejected by the one-sided test at 5 %).
    directions
        Directions of the tolerances' held-out signatures used (``m``).
    information
        Σ λᵢ: the tolerances' held-out variance at k = 1 over the noise's along those
        directions (how much the data can say about k; about 1 per informative direction).
    """

    estimate: float
    ci95: tuple[float, float]
    upper95: float
    directions: int
    information: float

    @property
    def exceeds(self) -> bool:
        """True where the interval lies above 1: the data show the rig's errors exceed what
        it states."""
        return self.ci95[0] > 1.0

    def to_json(self) -> dict[str, object]:
        return {
            "estimate": float(self.estimate),
            "ci95": [float(self.ci95[0]), float(self.ci95[1])],
            "upper95": float(self.upper95),
            "upper_bounded": bool(self.ci95[1] < K_MAX),
            "directions": int(self.directions),
            "information": float(self.information),
            "exceeds_stated": self.exceeds,
            "method": "maximum likelihood of the held-out nominal residual's components along "
            "the tolerances' leading held-out signatures (noise covariance from the floor's "
            "noise model, refitted), the interval by inverting the likelihood-ratio test "
            "calibrated by simulation (upper95: the upper end of its 90 % interval, a one-sided "
            "95 % bound); under the hypothesis of no effect",
        }


def _grid() -> FloatArray:
    return np.concatenate([[0.0], np.geomspace(0.05, K_MAX, 120)])


def _loglik(c2: FloatArray, lam: FloatArray, k: FloatArray) -> FloatArray:
    """Log-likelihood (up to a constant) of components with squares ``c2`` (m × B) at every
    scale of ``k`` (G): G × B."""
    v = 1.0 + np.outer(k * k, lam)  # G × m
    out: FloatArray = -0.5 * (np.log(v).sum(axis=1)[:, None] + (1.0 / v) @ c2)
    return out


def _fit(c2: FloatArray, lam: FloatArray, grid: FloatArray) -> tuple[FloatArray, FloatArray]:
    """(the maximum log-likelihood per column, the log-likelihood at every grid scale)."""
    ll = _loglik(c2, lam, grid)
    return ll.max(axis=0), ll


def scale_interval(
    c: FloatArray, lam: FloatArray, rng: np.random.Generator, *, draws: int = LR_DRAWS
) -> tuple[float, tuple[float, float], float]:
    """The estimate, 95 % interval and 95 % upper bound (the 90 % interval's upper end) of k
    from independent components ``c`` with variances ``k²·lam + 1`` (module docs)."""
    grid = _grid()
    best, ll = _fit((c * c)[:, None], lam, grid)
    lr_obs = 2.0 * (best[0] - ll[:, 0])
    k_hat = float(grid[int(np.argmax(ll[:, 0]))])
    z2 = rng.standard_normal((len(lam), draws)) ** 2
    p = np.zeros(len(grid))
    for i, k in enumerate(grid):
        sim = z2 * (1.0 + k * k * lam)[:, None]
        b, l_sim = _fit(sim, lam, grid)
        lr = 2.0 * (b - l_sim[i])
        p[i] = (1 + np.sum(lr >= lr_obs[i])) / (draws + 1)

    def ends(level: float) -> tuple[float, float]:
        inside = grid[p >= level]
        if not len(inside):  # only where the grid misses the estimate's neighbourhood
            return k_hat, k_hat
        return float(inside.min()), float(inside.max())

    return k_hat, ends(0.05), ends(0.10)[1]


def tolerance_scale(
    batch: Batch,
    design: DesignMatrix,
    floor: NoiseFloor,
    rng: np.random.Generator,
    *,
    columns: FloatArray | None = None,
) -> ToleranceScale | None:
    """k, the factor by which the rig's errors exceed its stated tolerances, from the nominal
    model's held-out residual (module docs); None where the rig states no tolerance that shows
    on the held-out runs.

    Parameters
    ----------
    batch
        The held-out fits of the diagnoser's design (:class:`.null.Batch`).
    design
        The design, with its tolerance signatures (``nuisance``).
    floor
        The noise floor whose noise model the replicates are drawn from.
    rng
        Random draws (the noise replicates and the interval's simulations).
    columns
        The model's effect columns (default: none, the nominal model): k then measures what
        is left once they are fitted too.
    """
    nuis = design.nuisance
    if nuis.shape[1] == 0:
        return None
    fb = batch.fit(columns, nuis)
    if fb is None or fb.hold_resid is None:
        return None
    b_ho = fb.hold_resid
    u, s, _ = np.linalg.svd(b_ho, full_matrices=False)
    ok = s > 1e-9 * max(float(s[0]), 1e-300)
    m = int(min(MAX_DIRECTIONS, ok.sum()))
    if m == 0:
        return None
    u, s = u[:, :m], s[:m]
    noise = batch.fit(columns, draw_noise(design, floor, NOISE_DRAWS, rng))
    if noise is None or noise.hold_resid is None:
        return None
    ce = u.T @ noise.hold_resid  # m × R
    cov = ce @ ce.T / ce.shape[1]  # zero-mean by construction
    # Whiten by the noise's covariance (Cholesky), then rotate to the eigenvectors of the
    # tolerances' covariance in that metric: independent components of variance k²λ + 1.
    try:
        chol = np.linalg.cholesky(cov)
    except np.linalg.LinAlgError:
        return None
    a = np.linalg.solve(chol, np.diag(s))  # C^{-1/2}·S
    lam, vec = np.linalg.eigh(a @ a.T)
    lam = np.maximum(lam, 0.0)
    data = batch.fit(columns, design.y[:, None])
    assert data is not None and data.hold_resid is not None
    c = vec.T @ np.linalg.solve(chol, u.T @ data.hold_resid[:, 0])
    est, ci, upper = scale_interval(c, lam, rng)
    return ToleranceScale(
        estimate=est, ci95=ci, upper95=upper, directions=m, information=float(lam.sum())
    )
