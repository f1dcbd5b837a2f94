"""The thermal camera's reading noise in the noise floor.

The floor (:mod:`.floor`) is the visit-to-visit repeatability of a model's residual. Part of
it is not the chips' or the poses' at all: each ROI's reading carries noise from visit to
visit, which the diagnosis smooths (:func:`.input_checks.smooth_temperatures`) but cannot
remove, and what is left of it moves the predicted spot by the model's sensitivity to that
reading. The sensitivity grows with the effects a model has: an unmodelled length or a
joint offset driven by a link's reading adds its slope to α's. A floor read on the residual of
a model with a large effect is therefore larger than the chips' and poses' repeatability by
that part (bench worlds with 0.03 K of reading noise per ROI, 2 µm at the chips, an effect at
four times the floor: the floor read 2.13–2.17 µm; 2.06–2.12 µm with the reading noise off).

This module measures that part so that the floor can be told as its two parts:

1. Each ROI's reading noise σ_T from the readings themselves: the raw readings less their
   smoothed series, whose mean square is σ_T² times that of white noise put through the same
   smoother (the smoother's own share, computed by drawing such noise).
2. Draws of that noise, smoothed as the readings were, put through the model (α's expansion
   and every effect's columns at their fitted amplitudes: :meth:`.tolerances.ModelNuisance.moved`),
   give the spots' part of it; the floor estimator (:func:`.floor.holdout_floor_draws`) read
   on those gives its share of the held-out floor.

The chips' and poses' part is then √(floor² − that share²) (the variogram is linear in the
covariance, so independent parts add in it).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

from thermrs.diagnose.floor import NoiseFloor, holdout_floor_draws
from thermrs.diagnose.tolerances import ModelNuisance, Term
from thermrs.signatures import VisitSet
from thermrs.stats import loess2

__all__ = ["reading_noise_k", "thermometer_floor"]

FloatArray = npt.NDArray[np.float64]

#: Draws of the reading noise put through the model (each a full set of series).
DRAWS = 8


def _smoothed_draws(
    vs: VisitSet, half_width_s: float, rng: np.random.Generator, k: int
) -> tuple[FloatArray, FloatArray]:
    """``k`` draws of unit white noise per visit (n × k) and the same smoothed per (run,
    camera) series as :func:`.input_checks.smooth_temperatures` smooths the readings."""
    z = rng.standard_normal((vs.n, k))
    s = np.empty_like(z)
    for g in vs.groups:
        t = vs.t_s[g] - vs.t_s[g][0]
        s[g] = loess2(t, z[g], half_width_s) if half_width_s > 0 else z[g]
    return z, s


def reading_noise_k(
    raw: VisitSet, smoothed: VisitSet, half_width_s: float, rng: np.random.Generator
) -> dict[str, float]:
    """Per ROI: the standard deviation (K) of its reading's visit-to-visit noise, from the raw
    readings less the smoothed ones (``raw`` and ``smoothed``: the same visits), corrected
    by the share white noise keeps through the same smoother."""
    z, s = _smoothed_draws(raw, half_width_s, rng, 4)
    kept = float(np.mean((z - s) ** 2))
    out: dict[str, float] = {}
    for name, v in raw.temps.items():
        if name == "ambient" or name not in smoothed.temps or kept <= 0:
            continue
        d = v - smoothed.temps[name]
        out[name] = float(np.sqrt(np.mean(d[np.isfinite(d)] ** 2) / kept))
    return out


def thermometer_floor(
    vs: VisitSet,
    nuisance: ModelNuisance,
    terms: Sequence[Term],
    coef: FloatArray,
    sigma_k: dict[str, float],
    floor: NoiseFloor,
    holdout_runs: set[str],
    half_width_s: float,
    rng: np.random.Generator,
) -> dict[str, Any] | None:
    """The reading noise's share of the held-out floor and the chips' and poses' rest.

    Parameters
    ----------
    vs
        The visits the model was fitted on (smoothed readings).
    nuisance
        The model's sensitivity to each reading (:class:`.tolerances.ModelNuisance`).
    terms, coef
        The model: its effects' (family, parameters, columns) and α then their amplitudes.
    sigma_k
        Each ROI's reading noise (:func:`reading_noise_k`).
    floor
        The held-out floor of the model's residual (its series' correlation time bound).
    holdout_runs
        The held-out runs.
    half_width_s
        The readings' smoother's half-width.
    rng
        The draws' generator.

    Returns
    -------
    ``thermometers_um`` (the reading noise's share), ``reading_noise_k`` and ``how``
    (:meth:`.floor.NoiseFloor.to_json` adds the rest, the chips' and poses'); None where there
    is nothing to split.
    """
    rois = [r for r in nuisance.rois if sigma_k.get(r, 0.0) > 0]
    if not rois or not np.isfinite(floor.holdout_um):
        return None
    smooth = {r: _smoothed_draws(vs, half_width_s, rng, DRAWS)[1] * sigma_k[r] for r in rois}
    moved = np.column_stack(
        [nuisance.moved(terms, coef, {r: smooth[r][:, j] for r in rois}) for j in range(DRAWS)]
    )
    rows = np.arange(2 * vs.n)
    got = holdout_floor_draws(vs, rows, moved, holdout_runs, floor.tau_c_max_s)
    got = got[np.isfinite(got)]
    if not len(got):
        return None
    thermo = float(np.sqrt(np.mean(got**2)))
    return {
        "thermometers_um": thermo,
        "reading_noise_k": {r: sigma_k[r] for r in rois},
        "how": "each ROI's reading noise (its raw readings less the smoothed ones, over the "
        "share white noise keeps through the smoother), drawn, smoothed as the readings are "
        f"and put through the model ({DRAWS} draws); the floor estimator read on those is the "
        "thermal camera's share; the chips' and poses' repeatability is the rest in quadrature",
    }
