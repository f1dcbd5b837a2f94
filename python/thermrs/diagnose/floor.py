"""The noise floor: what is noise by physics, not whatever the residual's slow part is.

A residual is compared against the measurement's own repeatability. That repeatability has
parts, each estimated from what it is and stated with how:

Centroid
    The scatter of the spot centroid between the frames of one visit (``u_std_um``,
    ``v_std_um`` and ``n_ok`` of the run table): the visit mean carries σ²/n of it. With one
    frame per visit it cannot be told from the visit repeatability and is reported as such.
Visit repeatability
    The visit-to-visit scatter at lags short against the thermal time scales, from a robust
    (Cressie–Hawkins) variogram of each (run, camera, axis) residual series over lags of up to
    the shortest thermal time constant (ten allowed correlation times, at most a third of the
    series): γ(h) = σ_w² + σ_a²·(1 − e^(−h/τ_c)) + c·h², white noise,
    a pose error correlated over τ_c, and a smooth structure that grows with the lag
    (non-negative least squares, τ_c profiled on a grid). The floor is √(σ_w² + σ_a²).
Correlated pose errors
    Allowed only with a correlation time τ_c at most one tenth of the shortest thermal time
    constant (one decade below it): anything slower is a gap to explain, never noise. The
    thermal time constants are the runs' own heating curves (first-order fits of every mapped
    link temperature per run, :func:`thermrs.heating.fit_curve`, kept where τ is determined to
    better than 50 %); without one, the shortest run's duration stands in for it.
Joint states
    Run tables carry no joint scatter; when a ``joint_std_urad`` column is present its rms is
    reported beside the others (it is already part of the visit repeatability).

Every held-out run gets its own floor (its series pooled); the floor a held-out residual is
compared with is theirs, never one pooled with the training runs.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from thermrs.errors import InputError
from thermrs.heating import Curve, fit_curve
from thermrs.memo import ContentCache, content_key
from thermrs.signatures import VisitSet

__all__ = [
    "NoiseFloor",
    "SeriesNoise",
    "holdout_floor_draws",
    "noise_floor",
    "thermal_time_scales",
]

FloatArray = npt.NDArray[np.float64]

#: A correlated pose error must decorrelate this many times faster than the fastest thermal
#: time constant to count as noise (one decade: a physical scale separation, not a fit).
SCALE_SEPARATION = 10.0
#: Largest relative standard error of a heating curve's τ to use it as a thermal time scale.
TAU_REL_SE = 0.5


@dataclass(frozen=True)
class SeriesNoise:
    """The noise model of one (run, camera, axis) residual series."""

    run: str
    camera: str
    axis: str
    n: int
    white_um: float
    correlated_um: float
    tau_c_s: float
    centroid_um: float | None

    @property
    def floor_um(self) -> float:
        """√(σ_w² + σ_a²)."""
        return float(np.hypot(self.white_um, self.correlated_um))


@dataclass
class NoiseFloor:
    """The floor and its parts (module docs)."""

    series: list[SeriesNoise]
    thermal_tau_min: dict[str, float]
    thermal_source: str
    tau_c_max_s: float
    per_run_um: dict[str, float]
    holdout_um: float
    train_um: float
    centroid_um: float | None
    centroid_note: str
    joints_um: float | None
    extra: dict[str, Any] = field(default_factory=dict)
    #: The held-out floor's standard error and 95 % interval (µm): the floor re-estimated on
    #: replicates of the null world (:func:`holdout_floor_draws`); unset until then.
    holdout_se_um: float | None = None
    holdout_ci95: tuple[float, float] | None = None

    def by_key(self) -> dict[tuple[str, str, str], SeriesNoise]:
        """The series' noise by (run, camera, axis)."""
        return {(s.run, s.camera, s.axis): s for s in self.series}

    def to_json(self) -> dict[str, Any]:
        """The floor's parts and how each was estimated (for the JSON and the report)."""
        white = _pool([s.white_um for s in self.series], [s.n for s in self.series])
        corr = _pool([s.correlated_um for s in self.series], [s.n for s in self.series])
        taus = [s.tau_c_s for s in self.series if s.correlated_um > 0]
        return {
            "holdout_um": self.holdout_um,
            "holdout_se_um": self.holdout_se_um,
            "holdout_ci95": None if self.holdout_ci95 is None else list(self.holdout_ci95),
            "holdout_uncertainty": "the floor re-estimated on replicates of the gap-free null "
            "world (noise and the rig's tolerances): their standard deviation, and the floor "
            "± 1.96 of it",
            "train_um": self.train_um,
            "per_run_um": self.per_run_um,
            "nominal_holdout_um": self.extra.get("nominal_holdout_um", self.holdout_um),
            "estimated_on": self.extra.get(
                "estimated_on", "the nominal model's residual (no effect named)"
            ),
            "parts": {
                "centroid_um": self.centroid_um,
                "centroid": self.centroid_note,
                "visit_white_um": white,
                "visit_white": "robust variogram of each residual series at short lags: the "
                "white (visit-to-visit independent) part",
                "pose_correlated_um": corr,
                "pose_correlation_time_min": float(np.median(taus)) / 60.0 if taus else None,
                "pose_correlated": "the variogram's correlated part, allowed only with a "
                f"correlation time ≤ {self.tau_c_max_s / 60.0:.1f} min (one tenth of the "
                "shortest thermal time constant); anything slower is gap",
                "joints_um": self.joints_um,
                "joints": "joint scatter is not in the run tables (it is part of the visit "
                "repeatability)"
                if self.joints_um is None
                else "rms of the joint states' reported scatter",
            },
            "thermal_time_constants_min": self.thermal_tau_min,
            "thermal_time_constants": self.thermal_source,
            "correlation_time_max_min": self.tau_c_max_s / 60.0,
            "series": [
                {
                    "run": s.run,
                    "camera": s.camera,
                    "axis": s.axis,
                    "n": s.n,
                    "floor_um": s.floor_um,
                    "white_um": s.white_um,
                    "correlated_um": s.correlated_um,
                    "correlation_time_min": s.tau_c_s / 60.0,
                }
                for s in self.series
            ],
        }


def _pool(values: list[float], weights: list[int]) -> float:
    w = np.asarray(weights, dtype=np.float64)
    v = np.asarray(values, dtype=np.float64)
    if w.sum() == 0:
        return float("nan")
    return float(np.sqrt(np.sum(w * v**2) / w.sum()))


#: Heating curves by the content of their samples (a proof diagnoses the user's runs again).
_CURVES: ContentCache[Curve] = ContentCache(256)


def _heating_curve(t_ns: npt.NDArray[np.int64], y: FloatArray, name: str) -> Curve:
    """:func:`thermrs.heating.fit_curve` of a series, kept by its samples (times in seconds
    from the first, as the fit takes them)."""
    t = (t_ns - t_ns[0]).astype(np.float64) / 1e9 if len(t_ns) else np.zeros(0)
    y = np.asarray(y, dtype=np.float64)
    return _CURVES.get(content_key(t, y, name), lambda: fit_curve(t, y, name=name))


def thermal_time_scales(visits: VisitSet, temperatures: list[str]) -> tuple[dict[str, float], str]:
    """The runs' own thermal time constants (minutes) by ``run/temperature``, and how they
    were found (module docs)."""
    out: dict[str, float] = {}
    names = [t for t in temperatures if visits.has(t) and t != "ambient"]
    for r in dict.fromkeys(visits.run.tolist()):
        m = visits.run == r
        cams = visits.camera[m]
        first = cams[0]
        sel = np.flatnonzero(m & (visits.camera == first))
        if len(sel) < 8:
            continue
        for name in names:
            try:
                c = _heating_curve(visits.t_ns[sel], visits.temps[name][sel], f"{r}/{name}")
            except InputError:
                continue
            if c.phase == "flat" or not np.isfinite(c.tau_s_se):
                continue
            if c.tau_s_se <= TAU_REL_SE * c.tau_s:
                out[f"{r}/{name}"] = float(c.tau_min)
    if out:
        return out, "first-order heating curves of the mapped link temperatures, per run"
    span = min(
        float(np.ptp(visits.t_s[visits.run == r])) for r in dict.fromkeys(visits.run.tolist())
    )
    return (
        {"shortest run": span / 60.0},
        "no heating curve determined: the shortest run's duration stands in",
    )


def _variogram(r: FloatArray, lags: npt.NDArray[np.intp]) -> FloatArray:
    """Cressie–Hawkins robust semivariogram at the given visit lags, of every column of ``r``
    (visits × series): lags × series."""
    out = np.empty((len(lags), r.shape[1]))
    for i, k in enumerate(lags):
        d = np.abs(r[k:] - r[:-k])
        out[i] = (np.mean(np.sqrt(d), axis=0) ** 4) / (0.457 + 0.494 / len(d)) / 2.0
    return out


#: The non-empty subsets of the variogram model's three terms (white, correlated, smooth).
_SUBSETS = [s for m in range(1, 8) if (s := [j for j in range(3) if m >> j & 1])]


def _nnls_many(a: FloatArray, g: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Non-negative least squares of every column of ``g`` (k × B) on the stacked designs
    ``a`` (T × k × 3): coefficients (T × 3 × B) and residual norms (T × B).

    The solution is the least-squares fit on one subset of the columns with every coefficient
    ≥ 0 (the Karush–Kuhn–Tucker conditions), and that fit has the least residual among all such
    feasible subset fits (each is a feasible point); with three columns, all seven subsets
    (and none) are tried at once for every design and column."""
    t_n, b_n = a.shape[0], g.shape[1]
    best_err = np.broadcast_to(np.linalg.norm(g, axis=0), (t_n, b_n)).copy()
    best = np.zeros((t_n, 3, b_n))
    for sub in _SUBSETS:
        c = np.linalg.pinv(a[:, :, sub]) @ g  # T × |S| × B
        err = np.linalg.norm(a[:, :, sub] @ c - g, axis=1)
        take = np.all(c >= 0.0, axis=1) & (err < best_err)
        best_err = np.where(take, err, best_err)
        for j in range(3):
            now = c[:, sub.index(j)] if j in sub else 0.0
            best[:, j] = np.where(take, now, best[:, j])
    return best, best_err


def series_noise_many(r: FloatArray, t: FloatArray, tau_c_max_s: float) -> FloatArray:
    """(σ_w, σ_a, τ_c) of every column of ``r`` (visits × series, sampled at the times ``t``)
    by the constrained variogram: series × 3, NaN where a series is too short. Columns with
    the same missing visits are fitted together."""
    r = np.asarray(r, dtype=np.float64)
    out = np.full((r.shape[1], 3), np.nan)
    if r.shape[1] == 0:
        return out
    ok = np.isfinite(r)
    patterns: dict[bytes, list[int]] = {}
    for b in range(r.shape[1]):
        patterns.setdefault(ok[:, b].tobytes(), []).append(b)
    for cols in patterns.values():
        keep = ok[:, cols[0]]
        got = _series_noise_same(r[keep][:, cols], t[keep], tau_c_max_s)
        if got is not None:
            out[cols] = got
    return out


def _series_noise_same(r: FloatArray, t: FloatArray, tau_c_max_s: float) -> FloatArray | None:
    """:func:`series_noise_many` of series with no missing visit (None if too short)."""
    if len(r) < 12:
        return None
    dt = float(np.median(np.diff(t))) if len(t) > 1 else 0.0
    if dt <= 0:
        return None
    # Lags up to the shortest thermal time constant (SCALE_SEPARATION allowed correlation
    # times): past the noise's own lags the smooth term is pinned by where the noise has
    # levelled off, so that it cannot absorb a correlated part near its allowed limit.
    k_max = int(np.clip(np.ceil(SCALE_SEPARATION * tau_c_max_s / dt), 4, len(r) // 3))
    lags = np.arange(1, k_max + 1)
    gam = _variogram(r, lags)
    h = lags * dt
    grid = np.geomspace(max(dt / 4.0, 1.0), max(tau_c_max_s, dt / 4.0 + 1), 24)
    taus = np.array([0.0, *[x for x in grid if not (x > tau_c_max_s and x > 0)]])
    corr = np.zeros((len(taus), len(h)))
    corr[1:] = 1.0 - np.exp(-h[None, :] / taus[1:, None])
    a = np.stack([np.ones_like(corr), corr, np.broadcast_to((h / h[-1]) ** 2, corr.shape)], axis=2)
    coef, err = _nnls_many(a, gam)
    coef[0, 1] = 0.0  # τ = 0: no correlated part
    # The first τ whose fit is better than every earlier one by more than 1e-12.
    pick = np.zeros(gam.shape[1], dtype=np.intp)
    best = err[0].copy()
    for i in range(1, len(taus)):
        better = err[i] < best - 1e-12
        pick = np.where(better, i, pick)
        best = np.where(better, err[i], best)
    cols = np.arange(gam.shape[1])
    w2 = coef[pick, 0, cols]
    a2 = coef[pick, 1, cols]
    tau = taus[pick]
    white = tau < dt  # decorrelated within one cycle: white at this sampling
    w2 = np.where(white, w2 + a2, w2)
    a2 = np.where(white, 0.0, a2)
    tau = np.where(white, 0.0, tau)
    return np.column_stack([np.sqrt(np.maximum(w2, 0.0)), np.sqrt(np.maximum(a2, 0.0)), tau])


def series_noise(
    r: FloatArray, t: FloatArray, tau_c_max_s: float
) -> tuple[float, float, float] | None:
    """(σ_w, σ_a, τ_c) of one series by the constrained variogram; None if too short
    (:func:`series_noise_many` of one column)."""
    got = series_noise_many(np.asarray(r, dtype=np.float64)[:, None], t, tau_c_max_s)[0]
    if not np.isfinite(got[0]):
        return None
    return float(got[0]), float(got[1]), float(got[2])


def holdout_floor_draws(
    visits: VisitSet,
    rows: npt.NDArray[np.intp],
    residuals: FloatArray,
    holdout_runs: set[str],
    tau_c_max_s: float,
) -> FloatArray:
    """The held-out floor re-estimated, as :func:`noise_floor` does, on every column of
    ``residuals`` (held-out rows ``rows`` of the 2n vector × replicates)."""
    n = visits.n
    where = {int(r): i for i, r in enumerate(rows)}
    series: list[tuple[npt.NDArray[np.intp], FloatArray, int]] = []
    for g in visits.groups:
        if str(visits.run[g[0]]) not in holdout_runs:
            continue
        for off in (0, n):
            pos = [where.get(int(i) + off, -1) for i in g]
            if min(pos) < 0:
                continue
            series.append((np.asarray(pos, dtype=np.intp), visits.t_s[g], len(g)))
    # Per series, every replicate at once; pooled per replicate over the series it has.
    num = np.zeros(residuals.shape[1])
    den = np.zeros(residuals.shape[1])
    for idx, t, m in series:
        got = series_noise_many(residuals[idx], t, tau_c_max_s)
        have = np.isfinite(got[:, 0])
        num[have] += m * (got[have, 0] ** 2 + got[have, 1] ** 2)
        den[have] += m
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(den > 0, np.sqrt(num / np.where(den > 0, den, 1.0)), np.nan)


def noise_floor(
    visits: VisitSet,
    residual: FloatArray,
    holdout_runs: set[str],
    temperatures: list[str],
) -> NoiseFloor:
    """The noise floor of residual series (module docs).

    Parameters
    ----------
    visits
        The visits (row order of ``residual``: u rows then v rows).
    residual
        The nominal model's residual per row (2n).
    holdout_runs
        Names of the held-out runs (each gets its own floor).
    temperatures
        The rig's mapped temperatures (for the thermal time scales).
    """
    taus, source = thermal_time_scales(visits, temperatures)
    tau_c_max_s = min(taus.values()) * 60.0 / SCALE_SEPARATION
    series: list[SeriesNoise] = []
    n = visits.n
    cen, cen_note = _centroid(visits)
    for g in visits.groups:
        run = str(visits.run[g[0]])
        cam = str(visits.camera[g[0]])
        for ax, off in (("u", 0), ("v", n)):
            got = series_noise(residual[g + off], visits.t_s[g], tau_c_max_s)
            if got is None:
                continue
            w, a, tau = got
            c = None if cen is None else cen.get((run, cam, ax))
            series.append(SeriesNoise(run, cam, ax, len(g), w, a, tau, c))
    if not series:
        # Series too short for a variogram: the plain von Neumann estimate per series.
        for g in visits.groups:
            for ax, off in (("u", 0), ("v", n)):
                r = residual[g + off]
                if len(r) > 2:
                    w = float(np.sqrt(np.mean(np.diff(r) ** 2) / 2.0))
                    series.append(
                        SeriesNoise(
                            str(visits.run[g[0]]),
                            str(visits.camera[g[0]]),
                            ax,
                            len(r),
                            w,
                            0,
                            0,
                            None,
                        )
                    )
    per_run: dict[str, float] = {}
    for r in dict.fromkeys(visits.run.tolist()):
        ss = [s for s in series if s.run == r]
        if ss:
            per_run[r] = _pool([s.floor_um for s in ss], [s.n for s in ss])
    hold = [s for s in series if s.run in holdout_runs]
    train = [s for s in series if s.run not in holdout_runs]
    joints = None
    if "joint_std_urad" in visits.table.columns:
        js = visits.table["joint_std_urad"].to_numpy().astype(np.float64)
        js = js[np.isfinite(js)]
        joints = float(np.sqrt(np.mean(js**2))) if len(js) else None
    all_cen = [s.centroid_um for s in series if s.centroid_um is not None]
    return NoiseFloor(
        series=series,
        thermal_tau_min=taus,
        thermal_source=source,
        tau_c_max_s=tau_c_max_s,
        per_run_um=per_run,
        holdout_um=_pool([s.floor_um for s in hold], [s.n for s in hold]) if hold else float("nan"),
        train_um=_pool([s.floor_um for s in train], [s.n for s in train])
        if train
        else float("nan"),
        centroid_um=float(np.sqrt(np.mean(np.square(all_cen)))) if all_cen else None,
        centroid_note=cen_note,
        joints_um=joints,
    )


def _centroid(visits: VisitSet) -> tuple[dict[tuple[str, str, str], float] | None, str]:
    """The centroid's share of each series' visit scatter, σ_frame²/n_ok (module docs)."""
    t = visits.table
    if not {"u_std_um", "v_std_um", "n_ok"} <= set(t.columns):
        return None, "the run tables carry no per-visit frame scatter"
    n_ok = t["n_ok"].to_numpy().astype(np.float64)
    if not np.any(n_ok > 1):
        return None, (
            "one frame per visit: the centroid's scatter cannot be told from the visit "
            "repeatability (it is part of it)"
        )
    out: dict[tuple[str, str, str], float] = {}
    for g in visits.groups:
        for ax in ("u", "v"):
            sd = t[f"{ax}_std_um"].to_numpy().astype(np.float64)[g]
            k = n_ok[g]
            m = np.isfinite(sd) & (k > 1)
            if m.any():
                out[(str(visits.run[g[0]]), str(visits.camera[g[0]]), ax)] = float(
                    np.sqrt(np.mean(sd[m] ** 2 / k[m]))
                )
    return out, "the scatter of the centroid between the frames of each visit, σ²/n per visit"
