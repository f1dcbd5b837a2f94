"""First-order heating curves of temperatures and drifts (issue #5, "Heating curves").

The paper (its Figure 5 and Table 4) finds every link temperature and the spot's drift along
the cameras' y axes to follow a first-order exponential, ``y = y0 + A·exp(−t/τ)``. This module
fits that form to a series by nonlinear least squares and tabulates the fits for every series
of a run table (:func:`thermrs.fit.run_table`) or of an extraction's thermal samples.

Model
    ``y(t) = y0 + A·exp(−(t − t0)/τ)`` with ``t0`` the first sample's time: ``y0`` is the
    asymptote (steady state), ``y0 + A`` the value at the first sample, ``τ`` the time
    constant. A rising series (warm-up of a temperature) has ``A < 0``, a falling one
    (cool-down) ``A > 0``. :attr:`Curve.phase` of :func:`fit_curve` names the direction of the
    *series*. In the tables (:func:`heating_curves`) a drift row's phase is named from the
    run's temperatures instead (whether the links warm or cool over that drift's span), since a
    drift's sign depends only on the chip's orientation: a warming axis may drift negative.

Fit
    :func:`scipy.optimize.curve_fit` (trust-region reflective, ``τ`` bounded), in time scaled
    by the series' span and values scaled by their range. Two starts: the data's own guess
    (``y0`` = last value, ``A`` = first − last, ``τ`` = time the series needs to cover 63 % of
    its change) and the best ``τ`` of a logarithmic grid with ``y0`` and ``A`` solved linearly
    for each (robust where the series ends far from its steady state); the lower sum of squares
    wins. Standard errors allow for residuals autocorrelated from sample to sample (a drift
    series' visit errors are): the covariance scaled by the residual variance, times the
    residuals' AR(1) variance inflation (1+ρ)/(1−ρ) (Kendall bias-corrected, at least 1,
    :func:`thermrs.stats.ar1_variance_inflation`), which is what autocorrelated errors do to
    the variance of a smooth fit (Geyer's effective sample size, tried first, reads high on
    90 samples: 86 % of |z| < 2 against 92 % for the AR(1) form at ρ 0.7). A flat curve's
    ``y0_se`` is the standard deviation over the square root of the series' effective sample
    size (:func:`thermrs.stats.effective_sample_size`).

Outcomes
    - fewer than 4 finite samples, all samples at one time, a fit that does not converge, or a
      ``τ`` that runs into its bounds (a straight line: ``τ`` far longer than the series; or a
      step: ``τ`` shorter than the sample spacing) raise :class:`thermrs.errors.InputError` with
      one line naming the series;
    - a series without a change beyond its noise (constant, or the fitted curve's change over
      the series, ``A·(exp(−span/τ) − 1)``, below ``flat_sigma`` of its standard errors; that
      change is well determined even where ``A`` and ``τ`` are not) is *not* an error: it
      returns a curve with ``phase="flat"``, ``y0`` the series' mean, ``A = 0``, ``τ`` NaN and
      a note saying why. Flatness is judged before the bounds: pure noise is flat, not a step.

The tables (:func:`heating_curves`, :func:`temperature_curves`) never fail for one bad series:
its row carries nulls and a ``note``.

Example
-------
>>> import numpy as np
>>> from thermrs.heating import fit_curve
>>> t = np.arange(0.0, 5400.0, 60.0)  # 90 min, one sample a minute
>>> c = fit_curve(t, 28.1 - 4.7 * np.exp(-t / 1200.0), name="link2")
>>> round(c.tau_min, 6), round(c.y0, 6), c.phase
(20.0, 28.1, 'warm-up')
>>> heating_curves(thermrs.fit.run_table(ex, rig))  # doctest: +SKIP
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt
import polars as pl
from scipy.optimize import OptimizeWarning, curve_fit

from thermrs.errors import InputError
from thermrs.stats import ar1_variance_inflation, effective_sample_size, lstsq_qr

__all__ = ["CURVE_SCHEMA", "Curve", "fit_curve", "heating_curves", "temperature_curves"]

FloatArray = npt.NDArray[np.float64]

#: Fewest samples a curve is fitted to (three parameters and one degree of freedom).
MIN_SAMPLES = 4
#: The share of its change a first-order curve covers after one time constant.
ONE_TAU = 1.0 - math.exp(-1.0)

#: Columns of :func:`heating_curves` and :func:`temperature_curves`.
CURVE_SCHEMA: dict[str, Any] = {
    "run": pl.String,
    "kind": pl.String,
    "series": pl.String,
    "camera": pl.String,
    "axis": pl.String,
    "y0": pl.Float64,
    "a": pl.Float64,
    "tau_min": pl.Float64,
    "y0_se": pl.Float64,
    "a_se": pl.Float64,
    "tau_min_se": pl.Float64,
    "rms": pl.Float64,
    "n": pl.Int64,
    "phase": pl.String,
    "t_start_ns": pl.Int64,
    "t_end_ns": pl.Int64,
    "note": pl.String,
}


@dataclass(frozen=True)
class Curve:
    """A fitted first-order curve ``y(t) = y0 + a·exp(−(t − t0_s)/tau_s)``.

    Attributes
    ----------
    y0, a, tau_s
        Asymptote, amplitude (value at ``t0_s`` minus ``y0``) and time constant (seconds).
        A flat curve has ``a = 0`` and ``tau_s`` NaN.
    y0_se, a_se, tau_s_se
        Their standard errors (autocorrelation-aware, see the module docstring). A flat
        curve has ``y0_se`` = standard error of the mean (effective sample size) and the
        others NaN.
    rms
        Root mean square of the residuals (divided by ``n``, not by the degrees of freedom).
    n
        Samples fitted.
    phase
        ``"warm-up"`` (rising, ``a < 0``), ``"cool-down"`` (falling, ``a > 0``) or ``"flat"``.
    t0_s
        The first sample's time (seconds, the caller's time base).
    note
        Why a curve is flat; empty otherwise.
    """

    y0: float
    a: float
    tau_s: float
    y0_se: float
    a_se: float
    tau_s_se: float
    rms: float
    n: int
    phase: str
    t0_s: float = 0.0
    note: str = ""

    @property
    def tau_min(self) -> float:
        """The time constant in minutes."""
        return self.tau_s / 60.0

    @property
    def tau_min_se(self) -> float:
        """The time constant's standard error in minutes."""
        return self.tau_s_se / 60.0

    def __call__(self, t_s: npt.ArrayLike) -> FloatArray:
        """The curve at times ``t_s`` (seconds, the same time base as the fitted samples)."""
        t = np.asarray(t_s, dtype=np.float64)
        if self.phase == "flat":
            return np.full_like(t, self.y0)
        return np.asarray(self.y0 + self.a * np.exp(-(t - self.t0_s) / self.tau_s))

    def to_json(self) -> dict[str, object]:
        """A JSON-ready document (NaN as null)."""
        return {
            "model": "y = y0 + a*exp(-(t - t0_s)/tau_s)",
            "y0": _num(self.y0),
            "a": _num(self.a),
            "tau_s": _num(self.tau_s),
            "tau_min": _num(self.tau_min),
            "y0_se": _num(self.y0_se),
            "a_se": _num(self.a_se),
            "tau_s_se": _num(self.tau_s_se),
            "tau_min_se": _num(self.tau_min_se),
            "rms": _num(self.rms),
            "n": self.n,
            "phase": self.phase,
            "t0_s": _num(self.t0_s),
            "note": self.note or None,
        }


def _num(x: float) -> float | None:
    return float(x) if math.isfinite(x) else None


def _model(x: FloatArray, c0: float, c1: float, k: float) -> FloatArray:
    return np.asarray(c0 + c1 * np.exp(-x / k))


def _flat(t0: float, y: FloatArray, note: str) -> Curve:
    n = len(y)
    mean = float(np.mean(y))
    return Curve(
        y0=mean,
        a=0.0,
        tau_s=math.nan,
        y0_se=float(np.std(y, ddof=1) / math.sqrt(effective_sample_size(y))) if n > 1 else math.nan,
        a_se=math.nan,
        tau_s_se=math.nan,
        rms=float(np.sqrt(np.mean((y - mean) ** 2))),
        n=n,
        phase="flat",
        t0_s=t0,
        note=note,
    )


def _tau_guess(x: FloatArray, z: FloatArray) -> float:
    """Time (scaled) at which the series first covers 63 % of its first-to-last change."""
    change = z[-1] - z[0]
    if change == 0:
        return 0.5
    covered = (z - z[0]) / change
    hit = np.flatnonzero(covered >= ONE_TAU)
    return float(x[hit[0]]) if len(hit) and x[hit[0]] > 0 else 0.5


def _inside(k: float, lo: float, hi: float) -> float:
    """``k`` moved strictly inside ``[lo, hi]`` (a start on a bound is infeasible)."""
    margin = (hi - lo) * 1e-3
    return min(max(k, lo + margin), hi - margin)


def _grid_start(x: FloatArray, z: FloatArray, lo: float, hi: float) -> tuple[float, float, float]:
    """The best τ of a logarithmic grid, y0 and A solved linearly for each."""
    best = (math.inf, 0.0, 0.0, 1.0)
    for k in np.geomspace(lo, hi, 61):
        basis = np.column_stack([np.ones_like(x), np.exp(-x / k)])
        coef, *_ = np.linalg.lstsq(basis, z, rcond=None)
        sse = float(np.sum((basis @ coef - z) ** 2))
        if sse < best[0]:
            best = (sse, float(coef[0]), float(coef[1]), float(k))
    return best[1], best[2], best[3]


def _change(
    x: FloatArray, z: FloatArray, popt: FloatArray, pcov: FloatArray, sse: float, *, fixed_tau: bool
) -> tuple[float, float]:
    """The fitted curve's change over the series, ``A·(exp(−span/τ) − 1)`` (scaled units, span
    1), and its standard error: by the delta method on the full covariance, or with τ held at
    its value where it sits on a bound (or the covariance is singular)."""
    c1, k = float(popt[1]), float(popt[2])
    e = math.exp(-1.0 / k)
    change = c1 * (e - 1.0)
    grad = np.array([0.0, e - 1.0, c1 * e / k**2])
    var = float(grad @ pcov @ grad) if not fixed_tau and np.all(np.isfinite(pcov)) else math.nan
    if not math.isfinite(var):
        basis = np.column_stack([np.ones_like(x), np.exp(-x / k)])
        try:
            lin = lstsq_qr(basis, z)
            var = (e - 1.0) ** 2 * float(lin.cov[1, 1]) * _inflation(lin.residuals)
        except ValueError:  # exp(−x/τ) indistinguishable from a constant: no change measurable
            var = math.inf
    return change, math.sqrt(max(var, 0.0))


def _inflation(r: FloatArray) -> float:
    """How much the residuals' autocorrelation inflates the variance of a smooth fit through
    them (≥ 1; :func:`thermrs.stats.ar1_variance_inflation`)."""
    return ar1_variance_inflation(r)


def fit_curve(
    t_s: npt.ArrayLike,
    y: npt.ArrayLike,
    *,
    tau_bounds_s: tuple[float, float] | None = None,
    flat_sigma: float = 3.0,
    name: str = "series",
) -> Curve:
    """Fit ``y = y0 + A·exp(−(t − t0)/τ)`` to samples (see the module docstring).

    Parameters
    ----------
    t_s
        Sample times, seconds (any origin; ``t0`` is the earliest). Need not be sorted.
    y
        Sample values. Non-finite samples (and their times) are dropped.
    tau_bounds_s
        Bounds on τ, seconds (``0 < low < high``). Default: the median sample spacing (a
        shorter τ is a step the sampling cannot resolve) to 1000 times the span of the series.
        A fit that ends on a bound raises (unless the series is flat).
    flat_sigma
        A fitted change over the series below this many of its standard errors counts as no
        change: the curve is returned flat.
    name
        The series' name, for messages.

    Returns
    -------
    Curve
        The fit, or a flat curve.

    Raises
    ------
    InputError
        Too few samples (< 4), no time span, bad bounds, no convergence, τ on a bound.

    Examples
    --------
    A cool-down from 30 °C towards 24 °C with a 45-minute time constant, sampled every two
    minutes:

    >>> import numpy as np
    >>> from thermrs.heating import fit_curve
    >>> t = np.arange(0.0, 4 * 3600.0, 120.0)
    >>> c = fit_curve(t, 24.0 + 6.0 * np.exp(-t / 2700.0), name="link3")
    >>> round(c.tau_min, 6), round(c.y0, 6), round(c.a, 6), c.phase
    (45.0, 24.0, 6.0, 'cool-down')
    """
    t, v = _samples(t_s, y, name=name)
    if not (math.isfinite(flat_sigma) and flat_sigma > 0):
        raise InputError(f"{name}: flat_sigma must be > 0, got {flat_sigma}")
    n = len(t)
    t0 = float(t[0])
    x = t - t0
    span = float(x[-1])
    lo_s, hi_s = _tau_bounds(x, tau_bounds_s, name=name)
    y_mid = float(np.mean(v))
    y_range = float(np.ptp(v))
    if y_range <= 1e-12 * max(1.0, float(np.max(np.abs(v)))):
        return _flat(t0, v, "constant series")

    # Scaled problem: time in spans, values in ranges about the mean.
    xs = x / span
    z = (v - y_mid) / y_range
    lo, hi = lo_s / span, hi_s / span
    sse, popt, pcov = _best_fit(xs, z, lo, hi, name=name)
    pcov = pcov * _inflation(z - _model(xs, *popt))
    c0, c1, k = (float(p) for p in popt)
    se = np.sqrt(np.clip(np.diag(pcov), 0.0, np.inf))
    y0 = y_mid + y_range * c0
    a = y_range * c1
    rms = y_range * math.sqrt(sse / n)
    on_bound = k <= lo * (1 + 1e-6) or k >= hi * (1 - 1e-6)
    change, change_se = _change(xs, z, popt, pcov, sse, fixed_tau=on_bound)
    if not (abs(change) >= flat_sigma * change_se):
        return _flat(
            t0,
            v,
            f"no change beyond noise: the fitted change {y_range * change:.3g} is below "
            f"{flat_sigma:g} × its SE {y_range * change_se:.3g}",
        )
    if on_bound:
        which = "lower" if k <= lo * (1 + 1e-6) else "upper"
        why = "a step" if which == "lower" else "no curvature, τ far longer than the series"
        raise InputError(
            f"{name}: τ ran into its {which} bound ({k * span:.4g} s): {why}, "
            "not a first-order curve"
        )
    return Curve(
        y0=y0,
        a=a,
        tau_s=k * span,
        y0_se=y_range * float(se[0]),
        a_se=y_range * float(se[1]),
        tau_s_se=span * float(se[2]),
        rms=rms,
        n=n,
        phase="warm-up" if a < 0 else "cool-down",
        t0_s=t0,
    )


def _samples(t_s: npt.ArrayLike, y: npt.ArrayLike, *, name: str) -> tuple[FloatArray, FloatArray]:
    """The finite samples in time order; at least :data:`MIN_SAMPLES` over a time span."""
    t = np.asarray(t_s, dtype=np.float64)
    v = np.asarray(y, dtype=np.float64)
    if t.ndim != 1 or t.shape != v.shape:
        raise InputError(f"{name}: times and values must be 1-D of equal length")
    ok = np.isfinite(t) & np.isfinite(v)
    t, v = t[ok], v[ok]
    order = np.argsort(t, kind="stable")
    t, v = t[order], v[order]
    n = len(t)
    if n < MIN_SAMPLES:
        raise InputError(
            f"{name}: {n} finite samples, too few for a heating curve (need {MIN_SAMPLES})"
        )
    if t[-1] - t[0] <= 0:
        raise InputError(f"{name}: all {n} samples are at one time")
    return t, v


def _tau_bounds(
    x: FloatArray, tau_bounds_s: tuple[float, float] | None, *, name: str
) -> tuple[float, float]:
    """τ's bounds, seconds: as given, or the median sample spacing to 1000 spans."""
    if tau_bounds_s is None:
        steps = np.diff(x)
        lo_s, hi_s = float(np.median(steps[steps > 0])), float(x[-1]) * 1e3
    else:
        lo_s, hi_s = tau_bounds_s
    if not (0 < lo_s < hi_s and math.isfinite(hi_s)):
        raise InputError(f"{name}: tau_bounds_s must satisfy 0 < low < high, got {tau_bounds_s}")
    return lo_s, hi_s


def _best_fit(
    xs: FloatArray, z: FloatArray, lo: float, hi: float, *, name: str
) -> tuple[float, FloatArray, FloatArray]:
    """(SSE, parameters, covariance) of the better of two starts (the data's own guess and a
    grid), fitted on the scaled problem with τ within [lo, hi]."""
    guess = (float(z[-1]), float(z[0] - z[-1]), _inside(_tau_guess(xs, z), lo, hi))
    g0, g1, gk = _grid_start(xs, z, lo, hi)
    starts = [guess, (g0, g1, _inside(gk, lo, hi))]
    best: tuple[float, FloatArray, FloatArray] | None = None
    errors: list[str] = []
    for p0 in starts:
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", OptimizeWarning)
                popt, pcov = curve_fit(
                    _model,
                    xs,
                    z,
                    p0=p0,
                    bounds=([-np.inf, -np.inf, lo], [np.inf, np.inf, hi]),
                    method="trf",
                    x_scale="jac",
                    ftol=1e-14,
                    xtol=1e-14,
                    gtol=1e-14,
                    max_nfev=2000,
                )
        except (RuntimeError, ValueError) as e:
            errors.append(str(e).splitlines()[0])
            continue
        sse = float(np.sum((_model(xs, *popt) - z) ** 2))
        if best is None or sse < best[0]:
            best = (sse, np.asarray(popt), np.asarray(pcov))
    if best is None:
        raise InputError(f"{name}: the heating-curve fit did not converge ({'; '.join(errors)})")
    return best


def _row(
    run: str,
    kind: str,
    series: str,
    camera: str | None,
    axis: str | None,
    t_ns: npt.NDArray[np.int64],
    y: FloatArray,
) -> dict[str, object]:
    """One table row: the curve of samples ``(t_ns, y)``, or nulls and a note."""
    ok = np.isfinite(y)
    t_ns, y = t_ns[ok], y[ok]
    label = series if camera is None else f"{series} (camera {camera}, axis {axis})"
    row: dict[str, object] = dict.fromkeys(CURVE_SCHEMA)
    row |= {"run": run, "kind": kind, "series": series, "camera": camera, "axis": axis}
    row["n"] = len(y)
    if len(t_ns):
        row["t_start_ns"] = int(t_ns.min())
        row["t_end_ns"] = int(t_ns.max())
    try:
        t_s = (t_ns - t_ns.min()).astype(np.float64) / 1e9 if len(t_ns) else np.zeros(0)
        c = fit_curve(t_s, y, name=f"run {run!r}, {label}")
    except InputError as e:
        row["note"] = str(e)
        return row
    row |= {
        "y0": c.y0,
        "a": c.a,
        "tau_min": _num(c.tau_min),
        "y0_se": _num(c.y0_se),
        "a_se": _num(c.a_se),
        "tau_min_se": _num(c.tau_min_se),
        "rms": c.rms,
        "n": c.n,
        "phase": c.phase,
        "note": c.note or None,
    }
    return row


def _frame(rows: Sequence[dict[str, object]]) -> pl.DataFrame:
    return pl.DataFrame(list(rows), schema=CURVE_SCHEMA)


def heating_curves(table: pl.DataFrame, *, run: str | None = None) -> pl.DataFrame:
    """First-order curves of every series of a run table.

    Per run: one row per temperature column (``<name>_c``: ``kind="temperature"``,
    ``series=name``, ``camera`` and ``axis`` null) fitted on the values at every visit time of
    the run (both cameras' visits, one sample per distinct time); and one row per camera and
    chip axis (``kind="drift"``, ``series="drift_u"`` / ``"drift_v"``) fitted on that camera's
    ``drift_u_um`` / ``drift_v_um``. A temperature row's ``phase`` is the direction of its
    series; a drift row's ``phase`` is that of the run's ROI temperatures over the camera's
    visits (``"warm-up"`` if their mean rises, ``"cool-down"`` if it falls), whatever the sign
    of the drift; ``"flat"`` if the drift does not change beyond its noise.

    The run table's temperatures are PCHIP interpolations of the thermal samples at the visit
    times (:func:`thermrs.fit.run_table`); where visits outnumber thermal frames these are not
    independent, and the standard errors of the temperature rows are optimistic. Fit the
    thermal samples themselves with :func:`temperature_curves` for honest errors.

    Parameters
    ----------
    table
        A run table (``run``, ``camera``, ``t_ns``, ``drift_u_um``, ``drift_v_um``, ``<name>_c``
        columns), one or several runs.
    run
        Only this run (default: every run in the table).

    Returns
    -------
    polars.DataFrame
        Columns :data:`CURVE_SCHEMA`: ``run, kind, series, camera, axis, y0, a, tau_min, y0_se,
        a_se, tau_min_se, rms, n, phase, t_start_ns, t_end_ns, note`` (``tau_min`` in minutes;
        ``y0``, ``a``, ``rms`` in °C or µm). A series that cannot be fitted has nulls and a
        ``note`` saying why; a flat one has ``phase="flat"``, ``a = 0``, null ``tau_min`` and a
        note.

    Raises
    ------
    InputError
        A required column is missing, or ``run`` is not in the table.

    Examples
    --------
    >>> import thermrs
    >>> table, _ = thermrs.fit.load_run_table("run1.parquet", thermrs.load_rig())  # doctest: +SKIP
    >>> curves = thermrs.heating.heating_curves(table)  # doctest: +SKIP
    >>> curves.select("series", "camera", "axis", "tau_min", "phase")  # doctest: +SKIP
    """
    need = ["run", "camera", "t_ns", "drift_u_um", "drift_v_um"]
    missing = [c for c in need if c not in table.columns]
    if missing:
        raise InputError(f"the run table has no column(s) {missing}")
    # Runs in time order (as the report's figures and Table 4 show them), not by name.
    first = table.group_by("run").agg(pl.col("t_ns").min()).sort("t_ns", "run")
    runs = [str(r) for r in first["run"].to_list()]
    if run is not None:
        if run not in runs:
            raise InputError(f"run {run!r} is not in the run table (runs: {runs})")
        runs = [run]
    temp_cols = sorted(c for c in table.columns if c.endswith("_c"))
    rows: list[dict[str, object]] = []
    for r in runs:
        tr = table.filter(pl.col("run") == r).sort("t_ns")
        per_time = tr.unique("t_ns", keep="first", maintain_order=True)
        t_ns = per_time["t_ns"].to_numpy().astype(np.int64)
        for col in temp_cols:
            y = per_time[col].cast(pl.Float64).to_numpy().astype(np.float64)
            rows.append(_row(r, "temperature", col[: -len("_c")], None, None, t_ns, y))
        for cam in sorted(set(tr["camera"].to_list())):
            tc = tr.filter(pl.col("camera") == cam)
            ct = tc["t_ns"].to_numpy().astype(np.int64)
            phase = _thermal_phase(tc, temp_cols)
            for axis in ("u", "v"):
                y = tc[f"drift_{axis}_um"].cast(pl.Float64).to_numpy().astype(np.float64)
                row = _row(r, "drift", f"drift_{axis}", cam, axis, ct, y)
                if row["phase"] in ("warm-up", "cool-down") and phase is not None:
                    row["phase"] = phase
                rows.append(row)
    return _frame(rows)


def _thermal_phase(rows: pl.DataFrame, temp_cols: Sequence[str]) -> str | None:
    """``"warm-up"`` or ``"cool-down"``: whether the mean of the rows' ROI temperatures (every
    ``<name>_c`` but ambient) rises or falls from the first row to the last (rows sorted by
    time); None without ROI temperatures or without a change."""
    cols = [c for c in temp_cols if c != "ambient_c"]
    if not cols or rows.height < 2:
        return None
    m = rows.select(pl.mean_horizontal([pl.col(c).cast(pl.Float64) for c in cols]))
    t = m.to_series().drop_nulls().drop_nans().to_numpy()
    if len(t) < 2 or t[-1] == t[0]:
        return None
    return "warm-up" if t[-1] > t[0] else "cool-down"


def temperature_curves(
    temperatures: pl.DataFrame, *, run: str = "run", temperature: str = "peak"
) -> pl.DataFrame:
    """First-order curves of every thermal series of an extraction, on all its samples.

    Parameters
    ----------
    temperatures
        The long table :attr:`thermrs.Extraction.temperatures` (``t_ns``, ``name``,
        ``temperature_c`` and, in newer extractions, ``peak_c``). It should hold one run.
    run
        The value of the ``run`` column.
    temperature
        ``"peak"`` (default; the de-noised ROI peak, as :func:`thermrs.fit.run_table` uses;
        falls back to ``temperature_c`` where the table has no ``peak_c``) or ``"max"`` (the
        ROI maximum).

    Returns
    -------
    polars.DataFrame
        The columns of :func:`heating_curves`, one ``kind="temperature"`` row per ``name``.

    Raises
    ------
    InputError
        A required column is missing, or ``temperature`` is not ``"peak"`` or ``"max"``.

    Examples
    --------
    >>> import thermrs
    >>> ex = thermrs.extract("run1.mcap", thermrs.load_rig())  # doctest: +SKIP
    >>> thermrs.heating.temperature_curves(ex.temperatures, run="run1")  # doctest: +SKIP
    """
    if temperature not in ("peak", "max"):
        raise InputError(f"temperature must be 'peak' or 'max', got {temperature!r}")
    column = "peak_c" if temperature == "peak" else "temperature_c"
    if column not in temperatures.columns:
        column = "temperature_c"
    missing = [c for c in ("t_ns", "name", column) if c not in temperatures.columns]
    if missing:
        raise InputError(f"the temperatures table has no column(s) {missing}")
    rows = []
    for name in sorted(set(temperatures["name"].drop_nulls().to_list())):
        s = temperatures.filter(pl.col("name") == name).sort("t_ns")
        t_ns = s["t_ns"].to_numpy().astype(np.int64)
        y = s[column].cast(pl.Float64).to_numpy().astype(np.float64)
        rows.append(_row(run, "temperature", name, None, None, t_ns, y))
    return _frame(rows)
