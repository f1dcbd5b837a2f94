"""Resampling whole cycles: statistics of a residual without pretending that the channels of
one cycle are independent.

Every camera, chip axis and run channel of a cycle carries the same effect and the same
thermal state, so a visit's u and v rows and the other camera's visit of the same cycle are
resampled together: the unit is the *cycle* (per run: the time since the run began divided by
the cycle time, the median time between two visits of one camera). Blocks of consecutive
cycles are drawn within each run (moving-block bootstrap, :func:`thermrs.stats.
moving_block_indices`); the block length is set by the data, from the AR(1) coefficient φ of
the per-cycle series being resampled: (1 + φ)/(1 − φ) cycles, its variance inflation (the
number of cycles one independent draw is worth), at least 1 and at most a quarter of a run.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from thermrs.signatures import VisitSet
from thermrs.stats import ar1_coefficient

__all__ = ["block_length", "cycle_units"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]


def cycle_units(visits: VisitSet) -> IntArray:
    """A cycle number per visit, unique across runs (module docs)."""
    out = np.zeros(visits.n, dtype=np.intp)
    base = 0
    for r in dict.fromkeys(visits.run.tolist()):
        m = visits.run == r
        gaps = []
        for g in visits.groups:
            if visits.run[g[0]] == r and len(g) > 1:
                gaps.append(np.diff(visits.t_s[g]))
        cyc = float(np.median(np.concatenate(gaps))) if gaps else 1.0
        cyc = cyc if cyc > 0 else 1.0
        k = np.floor(visits.t_since_start[m] / cyc + 1e-9).astype(np.intp)
        out[m] = base + k
        base += int(k.max()) + 1
    return out


def block_length(x: FloatArray) -> int:
    """Cycles per block from the series' AR(1) variance inflation (module docs)."""
    phi = min(max(ar1_coefficient(x), 0.0), 0.95)
    return int(np.clip(round((1 + phi) / (1 - phi)), 1, max(1, len(x) // 4)))
