"""Equal predictive accuracy of two fitted predictions on the held-out runs, neither taken for
the truth (Diebold and Mariano's question, answered given the runs).

With ``r_a`` and ``r_b`` the two predictions' held-out residuals (each held-out mounting's
mean removed), the loss differential is ``d = r_b² − r_a² = Δ (r_a + r_b)`` with
``Δ = r_b − r_a``, the difference of the two fitted predictions: fixed once they are fitted
on the training runs. Its mean is the advantage of ``a``; of the held-out noise ``e`` it
holds ``2 Δ·e / N`` and nothing else (``e²`` cancels). So, given the runs, the mean is normal
about the two predictions' true difference in mean square, with variance ``4 Δᵀ Σ Δ / N²``,
Σ the held-out noise's covariance: its channels, cycles and correlation as the floor's noise
model has them, taken here from draws of that model. Whether the effect's form is the
library's or only near it does not enter: the test compares what the two predict, on these
runs.

The diagnoser asks it of a selected effect's other choices (another joint, temperature, length
or camera), each rejected only where this test and the parametric one (the choice, as the
library writes it, the truth of a null world) both reject: intersection–union, the level held
under either null. The parametric test assumes the library's form exact; a world's effect never
quite is, and another choice of the same effect approximates it nearly as well: alone, it
excluded the true joint of a joint offset beside a second effect in 2 of 5 independent worlds
once the floor no longer read high. Between effects it is not asked: on the library's own forms
it costs the parametric test's power (a joint offset against an unmodelled length on 6-h runs of
the simulator: p 0.042 against < 0.001).

The same standard error is each candidate's ``gain_z`` denominator (:func:`gain_se`). (A
moving-block bootstrap of the differential's per-cycle sums, which gave it before, reads its
variance about a third low at a cycle-to-cycle correlation of 0.7; AR(1)-prewhitened, it counts
the two predictions' slow systematic difference as noise and keeps rivals a chip's drift leaves
four times the floor's mean square to.)
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt
from scipy.stats import norm

__all__ = ["NOISE_DRAWS", "equal_accuracy_p", "gain_se"]

FloatArray = npt.NDArray[np.float64]

#: Noise vectors drawn from the floor's model for one test or standard error.
NOISE_DRAWS = 400


def gain_se(r_a: FloatArray, r_b: FloatArray, noise: FloatArray) -> float:
    """The standard error of mean(r_b² − r_a²), the held-out gain of prediction ``a`` over
    ``b``, given the runs: the spread of its noise part 2 Δ·e / N over the ``noise`` draws
    (rows × draws), Δ = r_b − r_a (module docs)."""
    delta = r_b - r_a
    return float(np.std(2.0 * (delta @ noise) / len(delta), ddof=1))


def equal_accuracy_p(r_a: FloatArray, r_b: FloatArray, noise: FloatArray) -> float:
    """One-sided p that prediction ``b`` is at least as accurate as ``a`` on these rows
    (module docs).

    Parameters
    ----------
    r_a, r_b
        The two predictions' residuals on the same held-out rows (µm).
    noise
        Draws of the held-out noise on those rows (rows × draws), from the noise model.

    Returns
    -------
    float
        P(mean(r_b² − r_a²) ≥ the observed mean | the two equally accurate).
    """
    d = float(np.mean(r_b * r_b - r_a * r_a))
    se = gain_se(r_a, r_b, noise)
    if not se > 0:
        return 1.0 if d <= 0 else 0.0
    return float(norm.sf(d / se))
