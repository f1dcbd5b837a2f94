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
    The series is first detrended by a local quadratic over the thermal time scale, and the
    model's white and correlated terms are what those parts become once detrended (exact: a
    variogram is linear in the covariance; :mod:`.detrend`); each lag is weighted by √pairs over the
    variogram's smoothed level, so that the short lags, where the noise is most of it, set
    the noise. Without the two steps a gap left in the residual (a run heating and cooling,
    a chip's self-heating) was read as noise: on the nominal residual of 42 bench worlds with
    2 µm of noise and one effect at SNR 1–4 (fresh seeds, ``benchmarks/bench_floor_bias.py``),
    held-out floors of 1.73–2.81 µm (rms error 0.25 µm), now 1.76–2.34 µm (0.12 µm); without
    an effect unbiased as before (:func:`_grid_fit`).
    One pose error moves every chip of a run, so the series of a run share one τ_c: the one
    whose fits leave least over all of them (relative to each variogram's size). A τ_c
    shorter than the cycle is kept (an AR(1) of lag-one correlation e^(−cycle/τ_c) is not
    white). Fitted one series at a time, with τ_c under a cycle read as white, τ_c from 90
    visits was biased short (white noise of 1.3 µm and a pose error of 1.5 µm correlated
    over 17 min, a cycle of 10 min: median estimate 13 min, 37 % of the series read white),
    which gives the null world less slow power than the data have (:func:`pooled_noise`).
Channel correlation
    How the channels' (camera × chip axis) white parts correlate with each other and how
    their correlated parts do, from their cross-variograms with each run's τ_c, averaged
    over the runs (:func:`channel_correlations`): the slow part of a pose error is far more
    coherent across cameras and axes than the visit-to-visit scatter, and a null world
    drawing both with one correlation (that of the cycle-to-cycle increments) had a too
    narrow spread of every statistic summed over channels.
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

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from thermrs.diagnose.detrend import detrended_design
from thermrs.errors import InputError
from thermrs.heating import Curve, fit_curve
from thermrs.memo import ContentCache, content_key
from thermrs.signatures import VisitSet

__all__ = [
    "ChannelCorrelation",
    "NoiseFloor",
    "SeriesNoise",
    "as_correlation",
    "channel_correlations",
    "correlation_lags",
    "cross_variogram_parts",
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


@dataclass(frozen=True)
class ChannelCorrelation:
    """How the noise of one run's channels (camera × chip axis) is correlated: the white
    parts with each other, and the correlated parts with each other (one pose error moves
    every chip through the kinematics' Jacobian; at the chips its slow part is far more
    coherent across channels than the visit-to-visit scatter is)."""

    channels: tuple[tuple[str, str], ...]  # (camera, axis)
    white: FloatArray  # k × k correlation
    correlated: FloatArray  # k × k correlation


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
    #: Per run: how its channels' noise is correlated (:func:`channel_correlations`).
    correlations: dict[str, ChannelCorrelation] = field(default_factory=dict)

    def by_key(self) -> dict[tuple[str, str, str], SeriesNoise]:
        """The series' noise by (run, camera, axis)."""
        return {(s.run, s.camera, s.axis): s for s in self.series}

    def _thermometers(self) -> dict[str, Any] | None:
        """The held-out floor as its two parts: the thermal camera's reading noise through the
        model (``thermometers_um``, :mod:`.reading_noise`) and the rest, the chips' and poses'
        repeatability (``chips_um``, the floor's interval split alike: ``chips_ci95``)."""
        got = self.extra.get("thermometers")
        if got is None:
            return None
        thermo = float(got["thermometers_um"])

        def rest(x: float) -> float:
            return float(np.sqrt(max(x * x - thermo * thermo, 0.0)))

        ci = self.holdout_ci95
        return {
            **got,
            "chips_um": rest(self.holdout_um),
            "chips_ci95": None if ci is None else [rest(ci[0]), rest(ci[1])],
        }

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
            "thermometers": self._thermometers(),
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
            "channel_correlation": {
                run: {
                    "channels": [f"{cam}/{ax}" for cam, ax in c.channels],
                    "white": np.round(c.white, 4).tolist(),
                    "correlated": np.round(c.correlated, 4).tolist(),
                    "how": "cross-variograms of the run's channels with its correlation "
                    "time; the covariances averaged over the runs with the same channels",
                }
                for run, c in self.correlations.items()
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
    """Non-negative least squares of every column of ``g`` (T × k × B: per design) on the
    stacked designs ``a`` (T × B × k × 3: per design and column): coefficients (T × 3 × B)
    and residual norms (T × B).

    The solution is the least-squares fit on one subset of the columns with every coefficient
    ≥ 0 (the Karush–Kuhn–Tucker conditions), and that fit has the least residual among all such
    feasible subset fits (each is a feasible point); with three columns, all seven subsets
    (and none) are tried at once for every design and column."""
    t_n, b_n = a.shape[0], a.shape[1]
    gg = g.transpose(0, 2, 1)[..., None]  # T × B × k × 1
    best_err = np.linalg.norm(g, axis=1)
    best = np.zeros((t_n, 3, b_n))
    for sub in _SUBSETS:
        c = (np.linalg.pinv(a[..., sub]) @ gg)[..., 0]  # T × B × |S|
        err = np.linalg.norm((a[..., sub] @ c[..., None])[..., 0] - gg[..., 0], axis=2)
        take = np.all(c >= 0.0, axis=2) & (err < best_err)
        best_err = np.where(take, err, best_err)
        for j in range(3):
            now = c[:, :, sub.index(j)] if j in sub else 0.0
            best[:, j] = np.where(take, now, best[:, j])
    return best, best_err


def _tau_grid(dt: float, tau_c_max_s: float) -> FloatArray:
    """The correlation times tried: none, then 24 from a quarter of the sampling interval
    ``dt`` to the largest allowed, geometrically spaced."""
    grid = np.geomspace(max(dt / 4.0, 1.0), max(tau_c_max_s, dt / 4.0 + 1), 24)
    return np.array([0.0, *[x for x in grid if not (x > tau_c_max_s and x > 0)]])


#: The detrending smoother's Gaussian kernel σ, as a share of the shortest thermal time
#: constant: a local quadratic over about ± one thermal time constant follows a heating
#: curve's bend and leaves what varies faster than a tenth of it (the noise) in place.
DETREND_BANDWIDTH = 0.5
#: The log-variogram is averaged over this many neighbouring lags for the fit's weights.
WEIGHT_LAGS = 5


def _grid_fit(
    r: FloatArray, t: FloatArray, tau_c_max_s: float, taus: FloatArray
) -> tuple[FloatArray, FloatArray] | None:
    """The variogram model of every column of ``r`` (no missing visit) at every τ of
    ``taus``: coefficients (T × 3 × B, τ = 0 without a correlated part) and the residual
    norms relative to each column's (weighted) variogram (T × B); None if too short.

    The series is first detrended by a local quadratic over the thermal time scale
    (:data:`DETREND_BANDWIDTH`): a gap's slow structure is not quadratic in the lag out to
    the thermal time constant, and what the model's smooth term could not follow was read as
    noise (a floor 10–35 % high, or a white part pinned at zero, with a strong effect in
    the residual). The model's white and correlated columns are what those parts become
    once detrended, so the detrending costs no bias. The fit weighs each lag by
    √(pairs) / γ̂(h), γ̂ averaged in log over :data:`WEIGHT_LAGS` neighbouring lags
    (Cressie's weights with the empirical variogram, smoothed so that a lag's weight does
    not follow its own error): at the short lags the noise is most of the variogram,
    at the long ones what is left of a gap is."""
    if len(r) < 12:
        return None
    t = np.asarray(t, dtype=np.float64)
    dt = float(np.median(np.diff(t))) if len(t) > 1 else 0.0
    if dt <= 0:
        return None
    # Lags up to the shortest thermal time constant (SCALE_SEPARATION allowed correlation
    # times): past the noise's own lags the smooth term is pinned by where the noise has
    # levelled off, so that it cannot absorb a correlated part near its allowed limit.
    k_max = int(np.clip(np.ceil(SCALE_SEPARATION * tau_c_max_s / dt), 4, len(r) // 3))
    lags = np.arange(1, k_max + 1)
    bandwidth = DETREND_BANDWIDTH * SCALE_SEPARATION * tau_c_max_s
    det, white, corr = detrended_design(t, lags, taus, bandwidth)
    gam = _variogram(det @ r, lags)
    h = lags * dt
    a = np.stack(
        [np.broadcast_to(white, corr.shape), corr, np.broadcast_to((h / h[-1]) ** 2, corr.shape)],
        axis=2,
    )
    half = WEIGHT_LAGS // 2
    lg = np.pad(np.log(np.maximum(gam, 1e-300)), ((half, half), (0, 0)), mode="edge")
    smooth = np.exp(np.mean([lg[i : i + len(lags)] for i in range(WEIGHT_LAGS)], axis=0))
    wt = np.sqrt(len(t) - lags)[:, None] / smooth  # lags × B
    g = gam * wt
    coef, err = _nnls_many(
        a[:, None] * wt.T[None, :, :, None], np.broadcast_to(g, (len(taus), *g.shape))
    )
    coef[0, 1] = 0.0  # τ = 0: no correlated part
    scale = np.linalg.norm(g, axis=0)
    return coef, err / np.where(scale > 0, scale, 1.0)


def pooled_noise(
    sets: Sequence[tuple[FloatArray, FloatArray]], tau_c_max_s: float
) -> list[FloatArray]:
    """(σ_w, σ_a, τ_c) of the series of one process by the constrained variogram, with one
    correlation time for them all.

    Parameters
    ----------
    sets
        Per series, its values (visits × B: B replicates of it, NaN at missing visits) and
        the visits' times.
    tau_c_max_s
        The largest correlation time allowed (module docs).

    Returns
    -------
    list
        Per series, B × 3: (σ_w, σ_a, τ_c) of each replicate, NaN where the series is too
        short. In each replicate τ_c is the one that fits every series' variogram best
        (least sum of squared residuals relative to each variogram's size): one pose error
        moves every camera and axis with one correlation time, and a correlation time
        estimated on a hundred visits of one series alone is biased short.
    """
    dts = [
        float(np.median(np.diff(t))) for _, t in sets if len(t) > 1 and np.median(np.diff(t)) > 0
    ]
    out = [np.full((np.asarray(r).shape[1], 3), np.nan) for r, _ in sets]
    if not dts:
        return out
    taus = _tau_grid(min(dts), tau_c_max_s)
    fits: list[tuple[int, list[int], FloatArray, FloatArray]] = []
    b_n = max(np.asarray(r).shape[1] for r, _ in sets)
    total = np.zeros((len(taus), b_n))
    for i, (r, t) in enumerate(sets):
        r = np.asarray(r, dtype=np.float64)
        ok = np.isfinite(r)
        patterns: dict[bytes, list[int]] = {}
        for b in range(r.shape[1]):
            patterns.setdefault(ok[:, b].tobytes(), []).append(b)
        for cols in patterns.values():
            keep = ok[:, cols[0]]
            got = _grid_fit(r[keep][:, cols], np.asarray(t)[keep], tau_c_max_s, taus)
            if got is None:
                continue
            coef, err = got
            total[:, cols] += err**2
            fits.append((i, cols, coef, err))
    pick = np.argmin(total, axis=0)  # the first of equals: the shortest τ
    for i, cols, coef, _ in fits:
        p = pick[cols]
        c = np.arange(len(cols))
        w2, a2 = coef[p, 0, c], coef[p, 1, c]
        out[i][cols] = np.column_stack(
            [np.sqrt(np.maximum(w2, 0.0)), np.sqrt(np.maximum(a2, 0.0)), taus[p]]
        )
    return out


def series_noise_many(r: FloatArray, t: FloatArray, tau_c_max_s: float) -> FloatArray:
    """(σ_w, σ_a, τ_c) of every column of ``r`` (visits × series, sampled at the times ``t``)
    by the constrained variogram, each column on its own: series × 3, NaN where a series is
    too short."""
    return pooled_noise([(np.asarray(r, dtype=np.float64), t)], tau_c_max_s)[0]


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
    series: list[tuple[str, npt.NDArray[np.intp], FloatArray, int]] = []
    for g in visits.groups:
        run = str(visits.run[g[0]])
        if run not in holdout_runs:
            continue
        for off in (0, n):
            pos = [where.get(int(i) + off, -1) for i in g]
            if min(pos) < 0:
                continue
            series.append((run, np.asarray(pos, dtype=np.intp), visits.t_s[g], len(g)))
    # Per process, every replicate at once; pooled per replicate over the series it has.
    num = np.zeros(residuals.shape[1])
    den = np.zeros(residuals.shape[1])
    for members in _processes([run for run, _, _, _ in series]):
        sets = [(residuals[series[i][1]], series[i][2]) for i in members]
        for i, got in zip(members, pooled_noise(sets, tau_c_max_s), strict=True):
            m = series[i][3]
            have = np.isfinite(got[:, 0])
            num[have] += m * (got[have, 0] ** 2 + got[have, 1] ** 2)
            den[have] += m
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(den > 0, np.sqrt(num / np.where(den > 0, den, 1.0)), np.nan)


def _processes(runs: Sequence[str]) -> list[list[int]]:
    """The series (by index) that share one correlation time: every series of a run (one
    pose error moves all of a run's channels; runs may differ in speed and load)."""
    out: dict[str, list[int]] = {}
    for i, r in enumerate(runs):
        out.setdefault(r, []).append(i)
    return list(out.values())


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
        A model's residual per row (2n): the nominal model's, or one with effects.
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
    keys: list[tuple[str, str, str, int]] = []
    sets: list[tuple[FloatArray, FloatArray]] = []
    for g in visits.groups:
        for ax, off in (("u", 0), ("v", n)):
            keys.append((str(visits.run[g[0]]), str(visits.camera[g[0]]), ax, len(g)))
            sets.append((residual[g + off][:, None], visits.t_s[g]))
    for members in _processes([k[0] for k in keys]):
        got = pooled_noise([sets[i] for i in members], tau_c_max_s)
        for i, est in zip(members, got, strict=True):
            if not np.isfinite(est[0, 0]):
                continue
            run, cam, ax, m = keys[i]
            c = None if cen is None else cen.get((run, cam, ax))
            w, a, tau = (float(x) for x in est[0])
            series.append(SeriesNoise(run, cam, ax, m, w, a, tau, c))
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
    correlations = channel_correlations(visits, residual, series, tau_c_max_s)
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
        correlations=correlations,
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


def _nearest_correlation(c: FloatArray) -> FloatArray:
    """A symmetric matrix made a correlation matrix: eigenvalues at least 1e-6, unit
    diagonal."""
    c = np.clip((c + c.T) / 2.0, -1.0, 1.0)
    np.fill_diagonal(c, 1.0)
    w, v = np.linalg.eigh(c)
    c = (v * np.maximum(w, 1e-6)) @ v.T
    d = np.sqrt(np.diag(c))
    out: FloatArray = c / np.outer(d, d)
    return out


def channel_correlations(
    visits: VisitSet, residual: FloatArray, series: Sequence[SeriesNoise], tau_c_max_s: float
) -> dict[str, ChannelCorrelation]:
    """Per run, the correlation of its channels' white parts and of their correlated parts.

    The channels' residuals are put on the run's cycles (:func:`.resample.cycle_units`), and
    their cross-variograms ``½·E[Δx_i·Δx_j](h) = c_w + c_a·(1 − e^(−h/τ_c)) + c_s·(h/h_max)²``
    with the run's correlation time τ_c, over lags up to three of them
    (:func:`correlation_lags`), fitted by least squares entry by entry
    (:func:`cross_variogram_parts`); c_w and c_a, averaged over the runs with the same
    channels and normalised by their diagonals, are the two correlation matrices (a part
    absent from a channel is uncorrelated with the rest)."""
    from thermrs.diagnose.resample import cycle_units

    n = visits.n
    units = cycle_units(visits)
    tau_of = {(s.run, s.camera, s.axis): s.tau_c_s for s in series}
    parts: dict[tuple[tuple[str, str], ...], list[tuple[str, int, FloatArray, FloatArray]]] = {}
    for run in dict.fromkeys(visits.run.tolist()):
        groups = [g for g in visits.groups if visits.run[g[0]] == run]
        chans = [(g, ax, off) for g in groups for ax, off in (("u", 0), ("v", n))]
        keys = tuple((str(visits.camera[g[0]]), ax) for g, ax, _ in chans)
        taus = [tau_of.get((str(run), c, a)) for c, a in keys]
        k = len(chans)
        if k < 2 or len(set(keys)) < k or any(t is None for t in taus):
            continue
        cyc = np.unique(units[visits.run == run])
        mat = np.full((len(cyc), k), np.nan)
        for c, (g, _, off) in enumerate(chans):
            mat[np.searchsorted(cyc, units[g]), c] = residual[g + off]
        dts = [np.median(np.diff(visits.t_s[g])) for g in groups if len(g) > 1]
        dt = float(np.median(dts)) if dts else 0.0
        if dt <= 0 or len(cyc) < 12:
            continue
        tau = float(np.median(np.asarray(taus, dtype=np.float64)))
        cw, ca = cross_variogram_parts(mat, dt, tau, correlation_lags(tau, dt, len(cyc)))
        parts.setdefault(keys, []).append((str(run), len(cyc), cw, ca))
    # The chips sit at the same poses in every run: one pose error's mixing into the
    # channels is the runs' common one, so the covariances are averaged over the runs (by
    # their cycles) before they are made correlations (a ratio of one run's noisy estimates
    # is biased toward none).
    out: dict[str, ChannelCorrelation] = {}
    for keys, got in parts.items():
        w = np.array([m for _, m, _, _ in got], dtype=np.float64)
        white = as_correlation(np.tensordot(w, np.array([g[2] for g in got]), 1))
        has = [bool(np.any(g[3])) for g in got]
        correlated = (
            as_correlation(np.tensordot(w, np.array([g[3] for g in got]), 1))
            if any(has)
            else np.eye(len(keys))
        )
        for run_name, *_ in got:
            out[run_name] = ChannelCorrelation(keys, white, correlated)
    return out


def correlation_lags(tau_c_s: float, dt: float, cycles: int) -> int:
    """The longest lag (cycles) of the channels' cross-variograms: three correlation times,
    where the correlated part has reached 95 % of its sill (at least 4, at most a third of
    the run). A gap's slow structure grows with the lag, and every channel moves with it
    at once: over the series' own lags, out to the thermal time constant, it read as a
    coherent pose error, and the null world drew every effect of the robot's look-alikes
    as noise (a non-linear α at SNR 1 on 48-h runs lost to the thermal camera's drift)."""
    return int(np.clip(np.ceil(3.0 * tau_c_s / dt) + 1, 4, max(4, cycles // 3)))


def cross_variogram_parts(
    mat: FloatArray, dt: float, tau_c_s: float, k_max: int
) -> tuple[FloatArray, FloatArray]:
    """The covariances of k channels' white parts and of their correlated parts, from their
    cross-variograms (:func:`channel_correlations`).

    Parameters
    ----------
    mat
        The channels' residuals on a regular grid of cycles (cycles × k, NaN where missing).
    dt
        The cycle time (s).
    tau_c_s
        The channels' common correlation time (s; 0: no correlated part).
    k_max
        The longest lag (cycles).

    Returns
    -------
    white, correlated
        k × k covariance estimates (zeros where a part is absent).
    """
    k = mat.shape[1]
    lags = np.arange(1, k_max + 1)
    gam = np.empty((len(lags), k, k))
    for i, lag in enumerate(lags):
        d = mat[lag:] - mat[:-lag]
        f = np.isfinite(d).astype(np.float64)
        dz = np.where(np.isfinite(d), d, 0.0)
        cnt = f.T @ f
        gam[i] = (dz.T @ dz) / np.where(cnt > 0, 2.0 * cnt, np.inf)
    h = lags * dt
    corr = 1.0 - np.exp(-h / tau_c_s) if tau_c_s > 0 else np.zeros_like(h)
    x = np.column_stack([np.ones_like(h), corr, (h / h[-1]) ** 2])
    if tau_c_s <= 0:
        x = x[:, [0, 2]]
    coef = np.linalg.lstsq(x, gam.reshape(len(lags), k * k), rcond=None)[0].reshape(-1, k, k)
    return coef[0], (coef[1] if tau_c_s > 0 else np.zeros((k, k)))


def as_correlation(c: FloatArray) -> FloatArray:
    """A covariance estimate as a correlation matrix (:func:`_nearest_correlation`); a
    channel whose variance estimate is not positive uncorrelated with the rest."""
    dg = np.diag(c)
    ok = dg > 0
    sd = np.sqrt(np.where(ok, dg, 1.0))
    return _nearest_correlation(np.where(np.outer(ok, ok), c / np.outer(sd, sd), 0.0))
