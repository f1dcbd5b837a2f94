"""The share of the gap above the floor that the named effects close, with an interval that
carries the uncertainty of the held-out rms before, after, and of the floor together.

The share is ``(B − A) / (B − F)``: B the nominal model's held-out rms, A the rms with the
effects, F the noise floor. B and A are one draw each of what runs like these give (the
noise they happened to get), and F is estimated from the same residual. Their joint spread is
measured where the truth is known: in the world where the final model is the truth, with the
floor's noise model (:func:`.null.draw_noise`) and the rig drawn within its stated
tolerances (the null world's), every replicate refitted both ways and its floor estimated
again on the final model's residual, as the diagnosis does.

The interval is Fieller's for the ratio of the two differences ``D = B − A`` and
``G = B − F``, with their covariance from those replicates (F's variance at least the
square of the floor's own standard error, ``holdout_se_um``): the shares x for which
``D − x·G`` is within 1.96 of its standard deviation of 0 (the delta method made exact for
a ratio). Where the denominator is not itself significant (the gap above the floor within
its uncertainty), the interval is unbounded and none is stated.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt

from thermrs.diagnose.family_fit import DesignMatrix
from thermrs.diagnose.floor import NoiseFloor, holdout_floor_draws
from thermrs.diagnose.null import Batch, draw_noise

__all__ = ["closing_interval", "fieller"]

FloatArray = npt.NDArray[np.float64]

#: Replicates of the final model's world.
CLOSING_DRAWS = 99
#: The normal quantile of a two-sided 95 % interval.
Z95 = 1.959963984540054


def fieller(
    d: float, g: float, var_d: float, var_g: float, cov_dg: float, *, z: float = Z95
) -> tuple[float, float] | None:
    """Fieller's interval for ``d / g``: every x with ``(d − x·g)² ≤ z²·var(d − x·g)``; None
    where it is not a bounded interval (``g`` not significantly away from 0)."""
    a = g * g - z * z * var_g
    if a <= 0:
        return None
    b = d * g - z * z * cov_dg
    c = d * d - z * z * var_d
    disc = b * b - a * c
    if disc < 0:  # only with inconsistent (non positive semi-definite) moments
        return None
    r = float(np.sqrt(disc))
    return ((b - r) / a, (b + r) / a)


def closing_interval(
    batch: Batch,
    design: DesignMatrix,
    floor: NoiseFloor,
    columns: FloatArray,
    rng: np.random.Generator,
    *,
    draws: int = CLOSING_DRAWS,
    nuisance: FloatArray | None = None,
) -> dict[str, Any] | None:
    """The share closed and its 95 % interval (module docs); None where the model cannot be
    refitted or the floor not estimated.

    Parameters
    ----------
    batch
        The held-out fits of the diagnoser's design.
    design
        The design.
    floor
        The floor (estimated on the final model's residual): its noise model draws the
        replicates, its value is F.
    columns
        The final model's effect columns.
    rng
        Random draws.
    nuisance
        The rig's tolerances' signatures about the final model
        (:class:`.tolerances.ModelNuisance`; default: the nominal model's).
    """
    y = design.y[:, None]
    obs = batch.fit(columns, y, keep=True)
    if obs is None or obs.fitted is None or not np.isfinite(floor.holdout_um):
        return None
    sim = obs.fitted + draw_noise(design, floor, draws, rng)
    nuis = design.nuisance if nuisance is None else nuisance
    if nuis.shape[1]:
        sim = sim + nuis @ rng.standard_normal((nuis.shape[1], draws))
    ys = np.column_stack([y, sim])
    before = batch.fit(None, ys)
    after = batch.fit(columns, ys)
    if before is None or after is None or after.hold_resid is None:
        return None
    hold_runs = set(np.concatenate([design.vs.run, design.vs.run])[design.hold].tolist())
    fl = holdout_floor_draws(
        design.vs, batch.ho, after.hold_resid[:, 1:], hold_runs, floor.tau_c_max_s
    )
    b = np.sqrt(before.hold_ms)
    a = np.sqrt(after.hold_ms)
    ok = np.isfinite(fl) & np.isfinite(b[1:]) & np.isfinite(a[1:])
    if ok.sum() < 19:
        return None
    d_rep = (b[1:] - a[1:])[ok]
    c = np.cov(np.vstack([d_rep, b[1:][ok], fl[ok]]))  # D, B, F
    # The floor at least as uncertain as its own 95 % interval says (its spread in the
    # nominal model's null world), which covers the world's repeatability on the bench.
    var_f = max(float(c[2, 2]), float(floor.holdout_se_um or 0.0) ** 2)
    var_g = float(c[1, 1] + var_f - 2.0 * c[1, 2])
    cov_dg = float(c[0, 1] - c[0, 2])
    cov = np.array([[c[0, 0], cov_dg], [cov_dg, var_g]])
    bias = float(np.mean(fl[ok]) - floor.holdout_um)
    d0 = float(b[0] - a[0])
    g0 = float(b[0] - floor.holdout_um)
    ci = fieller(d0, g0, float(cov[0, 0]), var_g, cov_dg)
    return {
        "share": d0 / g0 if g0 > 0 else None,
        "ci95": None if ci is None else [float(ci[0]), float(ci[1])],
        "sd_removed_um": float(np.sqrt(cov[0, 0])),
        "sd_gap_um": float(np.sqrt(cov[1, 1])),
        "correlation": float(cov[0, 1] / np.sqrt(cov[0, 0] * cov[1, 1]))
        if cov[0, 0] > 0 and cov[1, 1] > 0
        else None,
        "floor_bias_um": bias,
        "sd_floor_um": float(np.sqrt(c[2, 2])),
        "draws": int(ok.sum()),
        "method": "Fieller's interval for (before − after) / (before − floor), the covariance "
        "of the two differences from replicates of the world where the final model is the "
        "truth (the floor's noise model, the rig within its stated tolerances; each replicate "
        "refitted with and without the effects and its floor estimated again), the floor's "
        "variance at least its own standard error squared",
    }
