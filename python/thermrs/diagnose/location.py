"""Where the residual lies: phases, the breakdown by run, camera, chip axis and phase, the
drivers it follows, and whether it is white (the noise floor is :mod:`.floor`).

Phases
    From the mean of the rig's mapped temperatures over each (run, camera) series, smoothed:
    ``warm-up`` where it rises faster than 0.1 K/h, ``cool-down`` where it falls faster, else
    ``plateau``.
Whiteness
    Ljung–Box on the held-out (or training) residual with 10 lags per series, the lag-1
    autocorrelation and the effective sample size (:func:`thermrs.stats.effective_sample_size`).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt
from scipy import stats as sps

from thermrs.signatures import VisitSet
from thermrs.stats import effective_sample_size

__all__ = ["drivers", "location_table", "phases", "whiteness"]

FloatArray = npt.NDArray[np.float64]

#: A temperature rate (K/h) above which a series is warming up or cooling down.
PHASE_RATE_K_PER_H = 0.1


def phases(visits: VisitSet, temperatures: list[str]) -> npt.NDArray[np.str_]:
    """``warm-up``, ``plateau`` or ``cool-down`` per visit (module docs)."""
    out = np.full(visits.n, "plateau", dtype=object)
    names = [t for t in temperatures if visits.has(t)]
    if not names:
        return out.astype(str)
    mean_t = np.mean([visits.temps[t] for t in names], axis=0)
    for g in visits.groups:
        t_h = visits.t_s[g] / 3600.0
        x = mean_t[g]
        if len(g) < 3 or t_h[-1] - t_h[0] <= 0:
            continue
        # Rate from a centred difference over about half an hour either side.
        half = max(1, int(np.searchsorted(t_h - t_h[0], 0.5)))
        lo = np.clip(np.arange(len(g)) - half, 0, len(g) - 1)
        hi = np.clip(np.arange(len(g)) + half, 0, len(g) - 1)
        dt = t_h[hi] - t_h[lo]
        rate = np.where(dt > 0, (x[hi] - x[lo]) / np.where(dt > 0, dt, 1.0), 0.0)
        out[g] = np.where(
            rate > PHASE_RATE_K_PER_H,
            "warm-up",
            np.where(rate < -PHASE_RATE_K_PER_H, "cool-down", "plateau"),
        )
    return out.astype(str)


def location_table(
    visits: VisitSet,
    residual: FloatArray,
    phase: npt.NDArray[np.str_],
    role: npt.NDArray[np.str_],
) -> list[dict[str, Any]]:
    """The residual broken down by run, camera, chip axis and phase: rms, bias, count and
    share of the total sum of squares."""
    run2 = np.concatenate([visits.run, visits.run])
    cam2 = np.concatenate([visits.camera, visits.camera])
    ph2 = np.concatenate([phase, phase])
    axis = visits.axis
    total = float(np.nansum(residual**2)) or 1.0
    rows = []
    keys = sorted(set(zip(run2.tolist(), cam2.tolist(), axis.tolist(), ph2.tolist(), strict=True)))
    for run, cam, ax, ph in keys:
        m = (run2 == run) & (cam2 == cam) & (axis == ax) & (ph2 == ph)
        r = residual[m]
        rows.append(
            {
                "run": run,
                "role": str(role[np.flatnonzero(m)[0] % visits.n]),
                "camera": cam,
                "axis": ax,
                "phase": ph,
                "n": int(m.sum()),
                "rms_um": float(np.sqrt(np.mean(r**2))),
                "bias_um": float(np.mean(r)),
                "share": float(np.sum(r**2) / total),
            }
        )
    return rows


def _rate(visits: VisitSet, x: FloatArray) -> FloatArray:
    out = np.zeros_like(x)
    for g in visits.groups:
        if len(g) > 2:
            out[g] = np.gradient(x[g], visits.t_s[g] / 3600.0)
    return out


def drivers(visits: VisitSet, residual: FloatArray) -> list[dict[str, Any]]:
    """Correlation of the residual (per chip axis) with each available driver: every
    temperature and its rate (K/h), and the time since the run began; p-values from the
    correlation's t statistic on the effective sample size."""
    out: list[dict[str, Any]] = []
    cands: dict[str, FloatArray] = {}
    for name, x in visits.temps.items():
        cands[f"{name} temperature"] = x
        cands[f"{name} rate"] = _rate(visits, x)
    cands["time since run start"] = visits.t_since_start
    for ax, sl in (("u", slice(0, visits.n)), ("v", slice(visits.n, 2 * visits.n))):
        r = residual[sl]
        n_eff = max(3.0, effective_sample_size(r, method="ar1"))
        for name, x in cands.items():
            # Within-series (centred per run and camera) correlation: offsets are free.
            xc = x.copy()
            rc = r.copy()
            for g in visits.groups:
                xc[g] -= xc[g].mean()
                rc[g] -= rc[g].mean()
            sx, sr = float(np.std(xc)), float(np.std(rc))
            if sx == 0 or sr == 0:
                continue
            c = float(np.mean(xc * rc) / (sx * sr))
            t = c * np.sqrt(max(n_eff - 2, 1.0) / max(1e-12, 1 - c * c))
            p = float(2 * sps.t.sf(abs(t), max(n_eff - 2, 1.0)))
            out.append({"driver": name, "axis": ax, "corr": c, "p": p, "n_eff": n_eff})
    out.sort(key=lambda d: -abs(d["corr"]))
    return out


def whiteness(
    residual: FloatArray, groups: npt.NDArray[np.str_], order: FloatArray
) -> dict[str, Any]:
    """Ljung–Box (10 lags, per series, combined), lag-1 autocorrelation and effective sample
    size of a residual."""
    q = 0.0
    dof = 0
    rho1 = []
    n_eff = 0.0
    n = 0
    for g in np.unique(groups):
        idx = np.flatnonzero(groups == g)
        idx = idx[np.argsort(order[idx])]
        r = residual[idx] - residual[idx].mean()
        m = len(r)
        if m < 15:
            continue
        den = float(np.sum(r * r)) or 1.0
        lags = min(10, m // 4)
        ac = np.array([np.sum(r[k:] * r[:-k]) / den for k in range(1, lags + 1)])
        q += float(m * (m + 2) * np.sum(ac**2 / (m - np.arange(1, lags + 1))))
        dof += lags
        rho1.append(ac[0])
        n_eff += effective_sample_size(r, method="ar1")
        n += m
    if dof == 0:
        return {"ljung_box_p": None, "rho1": None, "n_eff": None, "n": n, "white": None}
    p = float(sps.chi2.sf(q, dof))
    return {
        "ljung_box_p": p,
        "rho1": float(np.mean(rho1)),
        "n_eff": float(n_eff),
        "n": n,
        "white": bool(p > 0.01),
    }
