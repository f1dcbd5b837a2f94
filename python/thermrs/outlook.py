"""The rest of a run foreseen from what is recorded so far (``thermrs watch``).

The forward model predicts the drift from the links' temperatures; while a run is recorded
the temperatures to come are not known yet. Each temperature the model maps is extrapolated by
its first-order heating curve fitted to the run so far (:func:`thermrs.heating.fit_curve`:
``y0 + A·exp(−t/τ)``, the paper's Figure 5 form), and the drift to come is the forward model
at those temperatures with α (from training runs, or fitted on the run so far), anchored at
each camera's first visit of the run, as :func:`thermrs.predict.predict` anchors it.

The band is a 95 % prediction interval by simulation: α drawn from its interval (normal, its
standard error), each curve's ``y0``, ``A`` and ``τ`` from their standard errors (independent
normals, τ kept positive) and a measurement's scatter about the model (normal, the training
fit's residual rms), 400 draws, the 2.5 and 97.5 percentiles of the drift at each time.
A temperature whose curve cannot be fitted yet (fewer than four samples, a straight rise with
τ beyond its bounds) leaves the drift to come undetermined: the outlook is refused with that
reason (holding such a temperature at its last reading gave bands that missed the simulated
truth's end drift, ``benchmarks/bench_watch.py``).

When the drift leaves a tolerance: the first time the predicted drift's magnitude exceeds it,
with the 2.5–97.5 percentiles of that time over the draws (a draw that stays inside until the
horizon counts as "after the horizon").

Example
-------
>>> from thermrs.outlook import outlook
>>> o = outlook(run_so_far, rig, alpha_per_k=22e-6, alpha_se=0.4e-6, horizon_h=15)  # doctest: +SKIP
>>> o.crossings  # doctest: +SKIP
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import polars as pl

from thermrs.errors import InputError
from thermrs.fit import sensitivities
from thermrs.heating import Curve, fit_curve
from thermrs.model import ForwardModel
from thermrs.rig import Rig, as_rig

__all__ = ["DRAWS", "Outlook", "outlook", "run_hours"]

#: Monte Carlo draws of the band.
DRAWS = 400
#: Points of the predicted curve from now to the horizon.
GRID = 60


@dataclass(frozen=True)
class Outlook:
    """The drift to come, with its band, and when it leaves the tolerance.

    Attributes
    ----------
    now_h, horizon_h
        Hours since the run's first visit: the last visit so far, and the end foreseen.
    alpha_per_k, alpha_ci95
        α the prediction uses, and its 95 % interval.
    curve
        ``camera``, ``axis`` (``u``/``v``), ``hours``, ``predicted_um``, ``lo_um``, ``hi_um``
        from now to the horizon (drift from the camera's first visit).
    crossings
        Per camera and axis: ``now_um`` (the drift measured at the last visit),
        ``end_um``/``end_lo_um``/``end_hi_um`` (predicted at the horizon), ``leaves_h`` (when
        the predicted drift first exceeds the tolerance, null if not before the horizon),
        ``leaves_lo_h``, ``leaves_hi_h`` (its 95 % range; null bounds: after the horizon) and
        ``already`` (the measured drift is outside now).
    temperatures
        Per mapped temperature: ``name``, ``now_c``, ``end_c`` (at the horizon), ``tau_min``
        (null for a temperature flat so far).
    tolerance_um
        The tolerance on either axis (µm), or None.
    notes
        What the outlook assumes (a temperature flat so far held at its mean).
    """

    now_h: float
    horizon_h: float
    alpha_per_k: float
    alpha_ci95: tuple[float, float]
    curve: pl.DataFrame
    crossings: pl.DataFrame
    temperatures: pl.DataFrame
    tolerance_um: float | None
    notes: tuple[str, ...] = ()


def run_hours(run: pl.DataFrame) -> float:
    """Hours from a run table's first visit to its last.

    Parameters
    ----------
    run
        A run table (``t_ns``).

    Returns
    -------
    float
        The span in hours (0 for no visit).

    Examples
    --------
    >>> import polars as pl
    >>> run_hours(pl.DataFrame({"t_ns": [0, 5_400 * 10**9]}))
    1.5
    """
    if run.height == 0:
        return 0.0
    t = run["t_ns"]
    return float(int(t.max()) - int(t.min())) / 3.6e12  # type: ignore[arg-type]


def _curves(run: pl.DataFrame, names: list[str]) -> dict[str, Curve | float]:
    """Each temperature's heating curve over the run so far, or its last reading if none."""
    t0 = int(run["t_ns"].min())  # type: ignore[arg-type]
    by_time = run.unique("t_ns", keep="first").sort("t_ns")
    t_s = (by_time["t_ns"].to_numpy() - t0) / 1e9
    out: dict[str, Curve | float] = {}
    for n in names:
        y = by_time[f"{n}_c"].to_numpy().astype(np.float64)
        try:
            out[n] = fit_curve(t_s, y, name=n)
        except InputError:
            finite = y[np.isfinite(y)]
            out[n] = float(finite[-1]) if len(finite) else math.nan
    return out


def _draw_curve(c: Curve | float, t_s: np.ndarray, rng: np.random.Generator, k: int) -> np.ndarray:
    """``k`` draws of a temperature at times ``t_s`` (rows: draws)."""
    if not isinstance(c, Curve):
        return np.full((k, len(t_s)), c)

    def se(x: float) -> float:
        return x if math.isfinite(x) else 0.0

    if c.phase == "flat":
        return (c.y0 + se(c.y0_se) * rng.standard_normal(k))[:, None] + 0.0 * t_s[None, :]

    y0 = c.y0 + se(c.y0_se) * rng.standard_normal(k)
    a = c.a + se(c.a_se) * rng.standard_normal(k)
    tau = np.abs(c.tau_s + se(c.tau_s_se) * rng.standard_normal(k)) + 1e-9
    out: np.ndarray = y0[:, None] + a[:, None] * np.exp(-(t_s[None, :] - c.t0_s) / tau[:, None])
    return out


def _crossing(hours: np.ndarray, drift: np.ndarray, tol: float) -> np.ndarray:
    """Per row of ``drift`` (draws × times): the first hour its magnitude exceeds ``tol``
    (NaN: not before the last hour)."""
    out_ = np.abs(drift) > tol
    first = np.argmax(out_, axis=1).astype(np.float64)
    first[~out_.any(axis=1)] = np.nan
    ok = np.isfinite(first)
    res = np.full(drift.shape[0], np.nan)
    res[ok] = hours[first[ok].astype(int)]
    return res


def _foreseen(
    run: pl.DataFrame,
    rig: Rig,
    names: list[str],
    hours: np.ndarray,
    temps: dict[str, np.ndarray],
    alphas: np.ndarray,
    *,
    alpha_per_k: float,
    noise_um: float,
    tolerance_um: float | None,
    rng: np.random.Generator,
) -> tuple[list[dict[str, object]], list[dict[str, object]]]:
    """The drift to come per camera and axis (rows of the curve) and, per camera and axis,
    the drift now, at the horizon and when it leaves the tolerance."""
    draws = len(alphas)
    su_all, sv_all = sensitivities(run, rig)
    rows: list[dict[str, object]] = []
    cross: list[dict[str, object]] = []
    for cam in dict.fromkeys(run["camera"].to_list()):
        idx = np.flatnonzero((run["camera"] == cam).to_numpy())
        first = {"u": su_all[idx[0]], "v": sv_all[idx[0]]}
        fut = pl.DataFrame(
            {
                "camera": [cam] * (draws * GRID),
                **{f"{n}_c": temps[n].ravel() for n in names},
            }
        )
        su, sv = sensitivities(fut, rig)
        last = run[int(idx[-1])]
        for axis, s in (("u", su), ("v", sv)):
            d = alphas[:, None] * (s.reshape(draws, GRID) - first[axis])
            d = d + noise_um * rng.standard_normal(d.shape)
            central = alpha_per_k * (np.median(s.reshape(draws, GRID), axis=0) - first[axis])
            lo, hi = np.percentile(d, [2.5, 97.5], axis=0)
            rows += [
                {
                    "camera": cam,
                    "axis": axis,
                    "hours": float(h),
                    "predicted_um": float(p),
                    "lo_um": float(a),
                    "hi_um": float(b),
                }
                for h, p, a, b in zip(hours, central, lo, hi, strict=True)
            ]
            now_um = float(last[f"{axis}_um"].item()) - float(run[int(idx[0])][f"{axis}_um"].item())
            row: dict[str, object] = {
                "camera": cam,
                "axis": axis,
                "now_um": now_um,
                "end_um": float(central[-1]),
                "end_lo_um": float(lo[-1]),
                "end_hi_um": float(hi[-1]),
                "leaves_h": None,
                "leaves_lo_h": None,
                "leaves_hi_h": None,
                "already": bool(tolerance_um is not None and abs(now_um) > tolerance_um),
            }
            if tolerance_um is not None:
                c = _crossing(hours, central[None, :], tolerance_um)[0]
                x = np.sort(
                    np.where(np.isfinite(q := _crossing(hours, d, tolerance_um)), q, np.inf)
                )
                q_lo, q_hi = x[int(0.025 * (len(x) - 1))], x[int(np.ceil(0.975 * (len(x) - 1)))]
                row["leaves_h"] = float(c) if math.isfinite(c) else None
                row["leaves_lo_h"] = float(q_lo) if math.isfinite(q_lo) else None
                row["leaves_hi_h"] = float(q_hi) if math.isfinite(q_hi) else None
            cross.append(row)
    return rows, cross


def outlook(
    run: pl.DataFrame,
    rig: Rig | str,
    *,
    alpha_per_k: float,
    alpha_se: float,
    horizon_h: float,
    tolerance_um: float | None = None,
    noise_um: float = 0.0,
    draws: int = DRAWS,
    seed: int = 0,
) -> Outlook:
    """Foresee the drift of a run being recorded, to ``horizon_h`` hours after its first visit.

    Parameters
    ----------
    run
        The run table so far (:func:`thermrs.fit.run_table_from`: one row per visit with the
        mapped temperatures).
    rig
        The rig (a :class:`~thermrs.Rig` or the path of a rig file).
    alpha_per_k, alpha_se, horizon_h, tolerance_um
        α (1/K) and its standard error; the hours after the run's first visit the outlook
        reaches (the run's planned length); a tolerance on either chip axis (µm), or None.
    noise_um
        The scatter of a measured drift about the model (µm; e.g. the training fit's residual
        rms): the band is then a prediction interval for what will be measured.
    draws
        Monte Carlo draws of the band.
    seed
        Seed of the draws.

    Returns
    -------
    Outlook
        The drift to come with its band, and when it leaves the tolerance.

    Raises
    ------
    InputError
        The run table has no visit, lacks a temperature the rig maps, or a temperature's
        heating curve is not determined yet.

    Examples
    --------
    >>> o = outlook(run, rig, alpha_per_k=22e-6, alpha_se=5e-7, horizon_h=15)  # doctest: +SKIP
    """
    rig = as_rig(rig)
    if run.height == 0:
        raise InputError("the run has no visit with a spot yet")
    names = ForwardModel(rig, alpha_per_k=rig.alpha_per_k).temperature_names
    missing = [n for n in names if f"{n}_c" not in run.columns]
    if missing:
        raise InputError(f"the run has no temperatures for {missing} (the rig maps them)")
    run = run.sort("camera", "t_ns")
    now_h = run_hours(run)
    horizon_h = max(float(horizon_h), now_h)
    hours = np.linspace(now_h, horizon_h, GRID)
    t_s = hours * 3600.0
    curves = _curves(run, names)
    held = [n for n, c in curves.items() if not isinstance(c, Curve)]
    if held:
        raise InputError(
            f"the heating curve of {', '.join(held)} is not determined yet (a straight rise "
            "or too few readings so far): the drift to come waits for it"
        )
    rng = np.random.default_rng(seed)
    temps = {n: _draw_curve(c, t_s, rng, draws) for n, c in curves.items()}
    alphas = alpha_per_k + alpha_se * rng.standard_normal(draws)
    rows, cross = _foreseen(
        run, rig, names, hours, temps, alphas,
        alpha_per_k=alpha_per_k, noise_um=noise_um, tolerance_um=tolerance_um, rng=rng,
    )  # fmt: skip
    notes: list[str] = []
    trows = []
    for n, c in curves.items():
        assert isinstance(c, Curve)
        flat = c.phase == "flat"
        if flat:
            notes.append(f"{n}: no change beyond its noise so far (held at its mean)")
        trows.append(
            {
                "name": n,
                "now_c": float(run.sort("t_ns")[f"{n}_c"][-1]),
                "end_c": float(c(np.array([horizon_h * 3600.0]))[0]),
                "tau_min": None if flat else c.tau_min,
            }
        )
    lo_a, hi_a = alpha_per_k - 1.96 * alpha_se, alpha_per_k + 1.96 * alpha_se
    return Outlook(
        now_h=now_h,
        horizon_h=horizon_h,
        alpha_per_k=alpha_per_k,
        alpha_ci95=(lo_a, hi_a),
        curve=pl.DataFrame(rows),
        crossings=pl.DataFrame(cross),
        temperatures=pl.DataFrame(trows),
        tolerance_um=tolerance_um,
        notes=tuple(notes),
    )
