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
from scipy.optimize import nnls

from thermrs.errors import InputError
from thermrs.heating import fit_curve
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
                c = fit_curve(visits.t_s[sel], visits.temps[name][sel], name=f"{r}/{name}")
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


def _variogram(r: FloatArray, t: FloatArray, lags: npt.NDArray[np.intp]) -> FloatArray:
    """Cressie–Hawkins robust semivariogram at the given visit lags."""
    out = np.empty(len(lags))
    for i, k in enumerate(lags):
        d = np.abs(r[k:] - r[:-k])
        n = len(d)
        out[i] = (np.mean(np.sqrt(d)) ** 4) / (0.457 + 0.494 / n) / 2.0
    return out


def series_noise(
    r: FloatArray, t: FloatArray, tau_c_max_s: float
) -> tuple[float, float, float] | None:
    """(σ_w, σ_a, τ_c) of one series by the constrained variogram; None if too short."""
    ok = np.isfinite(r)
    r, t = r[ok], t[ok]
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
    gam = _variogram(r, t, lags)
    h = lags * dt
    best: tuple[float, float, float, float] | None = None
    taus = [0.0, *list(np.geomspace(max(dt / 4.0, 1.0), max(tau_c_max_s, dt / 4.0 + 1), 24))]
    for tau in taus:
        if tau > tau_c_max_s and tau > 0:
            continue
        corr = np.zeros_like(h) if tau == 0 else 1.0 - np.exp(-h / tau)
        a = np.column_stack([np.ones_like(h), corr, (h / h[-1]) ** 2])
        coef, err = nnls(a, gam)
        if tau == 0:
            coef[1] = 0.0
        if best is None or err < best[0] - 1e-12:
            best = (float(err), float(coef[0]), float(coef[1]), float(tau))
    assert best is not None
    _, w2, a2, tau = best
    if tau < dt:  # decorrelated within one cycle: white at this sampling
        w2, a2, tau = w2 + a2, 0.0, 0.0
    return float(np.sqrt(max(w2, 0.0))), float(np.sqrt(max(a2, 0.0))), tau


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
    out = np.full(residuals.shape[1], np.nan)
    for b in range(residuals.shape[1]):
        vals, wts = [], []
        for idx, t, m in series:
            got = series_noise(residuals[idx, b], t, tau_c_max_s)
            if got is not None:
                vals.append(float(np.hypot(got[0], got[1])))
                wts.append(m)
        if vals:
            out[b] = _pool(vals, wts)
    return out


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
