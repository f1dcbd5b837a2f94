"""Fitting the expansion coefficient α on the forward model (SPEC §4, §7 ``thermrs fit``).

Run tables
    One row per visit with the temperatures at its time: :mod:`thermrs.runtable`
    (:func:`run_table`, :func:`run_table_from`, re-exported here); from files,
    :func:`load_run_table` (:func:`thermrs.runs.load_runs`).

Time-series estimator
    For visit i of camera c in run r, the spot's position on the chip (u, v) is modelled as
    ``offset[c, r, axis] + α · s_i``, where ``s_i`` is the forward model's displacement per unit
    α of the spot at camera c's taught pose from the reference temperature to the visit's
    mapped temperatures (the model is linear in α to far below a nanometre over the range of
    interest; ``s_i`` is evaluated at the rig's α). The offsets absorb each camera's unknown
    mounting in each run (SPEC §4: absolute positions carry unknown offsets), so no single
    anchor visit carries the noise. α and the offsets come from one linear least-squares fit,
    weighted per camera and chip axis by the inverse of that axis's residual variance
    (feasible weighted least squares: an unweighted fit first gives the variances), solved
    by QR on unit-norm columns (:func:`thermrs.stats.lstsq_qr`: the sensitivity column,
    of order 10⁶–10⁷ µm per unit α, beside unit offset columns, loses no precision; a
    pseudo-inverse of the normal matrix at the default cutoff dropped the offsets' directions
    and gave intervals 4× too narrow).

    The errors of a visit series are not independent: pose repeatability, centroid bias and
    anything the model leaves out drift from visit to visit, and u moves with v within a
    visit. The covariance of α is therefore a Newey–West sandwich over each (run, camera)
    series of visits (a visit's u and v rows together as one unit), prewhitened by an AR(1)
    of α's influence series from visit to visit, with a data-chosen bandwidth, and the 95 %
    interval Student-t with degrees of freedom that shrink as that AR(1) grows
    (:meth:`thermrs.stats.LeastSquares.interval`). :class:`AlphaFit` says so (``interval``)
    and gives the effective number of independent visits (``n_eff``). Coverage on three rig
    geometries with AR(1), u–v-correlated visit errors: BENCHMARKS.md.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import polars as pl

from thermrs.errors import InputError
from thermrs.model import ForwardModel
from thermrs.rig import as_rig
from thermrs.runs import load_runs
from thermrs.runtable import RUN_COLUMNS, run_table, run_table_from

# Run tables live in thermrs.runtable; these names stay importable from here.
from thermrs.runtable import RigLike as RigLike
from thermrs.runtable import interpolate as interpolate
from thermrs.runtable import run_name as run_name
from thermrs.stats import lstsq_qr

__all__ = [
    "RUN_COLUMNS",
    "AlphaFit",
    "FitResult",
    "StartEndFit",
    "fit_alpha",
    "fit_alpha_start_end",
    "fit_document",
    "load_run_table",
    "run_table",
    "run_table_from",
    "training_alphas",
    "training_axes",
]


def load_run_table(
    path: str | os.PathLike[str],
    rig: RigLike,
    *,
    run: str | None = None,
    temperature: str = "peak",
) -> tuple[pl.DataFrame, bool]:
    """The run table of a recording or of the tables ``thermrs extract`` wrote.

    Parameters
    ----------
    path
        A recording (``.mcap``, extracted here) or any of the tables ``thermrs extract``
        wrote (``OUT.parquet``, ``OUT.visits.parquet``, …: the visits and temperatures
        tables beside it are read); ``path#run`` selects one run of the file (see
        :mod:`thermrs.runs`), and a file of several runs gives them all, one after the other,
        each named ``<run>#<name>``.
    rig
        The rig it was recorded on (a :class:`~thermrs.Rig` or the path of a rig file).
    run
        The run's name (default: the file's name without its suffixes, :func:`run_name`).
    temperature
        ``"peak"`` (default) or ``"max"``; see :func:`run_table_from`.

    Returns
    -------
    tuple[polars.DataFrame, bool]
        The run table and whether the recording lost data (for tables: whether the
        recording they were extracted from did, as recorded in their Parquet metadata).

    Raises
    ------
    InputError
        The file does not exist, is a directory, or is not a recording or extracted tables.
    RecordingError
        The recording cannot be used (see :func:`thermrs.extract`).

    Examples
    --------
    >>> import thermrs
    >>> table, lost = thermrs.fit.load_run_table("run1.parquet", "rig.toml")  # doctest: +SKIP
    """
    rt = load_runs(Path(path), as_rig(rig), name=run, temperature=temperature)
    return pl.concat(rt.tables, how="diagonal_relaxed"), rt.data_loss


@dataclass(frozen=True)
class AlphaFit:
    """The time-series fit of α."""

    alpha_per_k: float
    ci95: tuple[float, float]
    rms_um: float
    n_visits: int
    residuals: pl.DataFrame
    #: Standard error of α (1/K).
    stderr: float = float("nan")
    #: How the interval was obtained, in words.
    interval: str = ""
    #: Effective number of independent visits (autocorrelation taken into account).
    n_eff: float = float("nan")
    #: AR(1) coefficient of α's influence series from visit to visit (what the standard
    #: error was prewhitened with; 0 for independent visits).
    ar1: float = float("nan")

    def to_json(self) -> dict[str, object]:
        """The SPEC §7 ``thermrs fit --json`` document (extended)."""
        return {
            "alpha_per_k": {
                "value": self.alpha_per_k,
                "ci95": list(self.ci95),
                "stderr": self.stderr,
            },
            "rms_um": self.rms_um,
            "n_visits": self.n_visits,
            "n_eff": self.n_eff,
            "interval": self.interval,
            "ar1": self.ar1,
            "estimator": "time-series least squares on the forward model, "
            "per-camera-and-run offsets",
        }


def sensitivities(table: pl.DataFrame, rig: RigLike) -> tuple[np.ndarray, np.ndarray]:
    """Per row: the spot's displacement (u, v) in µm per unit α at the camera's taught pose,
    from the reference temperature to the row's mapped temperatures.

    Parameters
    ----------
    table
        A run table (``camera`` and one ``<name>_c`` column per mapped temperature).
    rig
        The rig (a :class:`~thermrs.Rig` or the path of a rig file).

    Returns
    -------
    tuple[numpy.ndarray, numpy.ndarray]
        ``(su, sv)``: µm per unit α along the chip's u and v axes, one value per row.

    Raises
    ------
    InputError
        The table lacks a temperature the rig maps.
    """
    rig = as_rig(rig)
    alpha0 = rig.alpha_per_k
    model = ForwardModel(rig, alpha_per_k=alpha0)
    names = model.temperature_names
    missing = [n for n in names if f"{n}_c" not in table.columns]
    if missing:
        raise InputError(f"the run table has no temperatures for {missing} (the rig maps them)")
    su = np.empty(table.height)
    sv = np.empty(table.height)
    for cam in rig.cameras:
        idx = np.flatnonzero((table["camera"] == cam.name).to_numpy())
        if not len(idx):
            continue
        q = rig.camera_pose(cam.name).joints_rad
        temps = {n: table[f"{n}_c"].to_numpy()[idx] for n in names}
        hot = model.spots(cam.name, q, temperatures=temps)
        ref = model.spots(cam.name, q, temperatures={n: rig.reference_c for n in names})
        su[idx] = (hot.u_um - ref.u_um[0]) / alpha0
        sv[idx] = (hot.v_um - ref.v_um[0]) / alpha0
    return su, sv


def check_tables(tables: Any, *, what: str = "tables") -> list[pl.DataFrame]:
    """``tables`` as a non-empty list of run tables, or a clear error.

    Raises
    ------
    TypeError
        ``tables`` is a single DataFrame or not a sequence of DataFrames.
    InputError
        ``tables`` is empty, or a table lacks the run table's columns (:data:`RUN_COLUMNS`).
    """
    if isinstance(tables, pl.DataFrame):
        raise TypeError(
            f"{what} must be a list of run tables; for one table write [table] "
            "(a polars DataFrame was given)"
        )
    if isinstance(tables, (str, bytes, os.PathLike)) or not isinstance(tables, Sequence):
        raise TypeError(
            f"{what} must be a list of run tables (polars DataFrames), not {type(tables).__name__}"
        )
    if len(tables) == 0:
        raise InputError(f"{what}: no run table given (an empty list)")
    for i, t in enumerate(tables):
        if not isinstance(t, pl.DataFrame):
            raise TypeError(
                f"{what}[{i}] must be a run table (polars DataFrame), not {type(t).__name__}"
            )
        lacking = [c for c in RUN_COLUMNS if c not in t.columns]
        if lacking:
            raise InputError(
                f"{what}[{i}] is not a run table: no column(s) {lacking} "
                "(see thermrs.fit.run_table)"
            )
    return list(tables)


def fit_alpha(tables: Sequence[pl.DataFrame], rig: RigLike) -> AlphaFit:
    """Fit α over every run table given (see the module docstring).

    Parameters
    ----------
    tables
        Run tables (:func:`run_table`, :func:`load_run_table`), one per run; a list even for
        one run.
    rig
        The rig the runs were recorded on (a :class:`~thermrs.Rig` or the path of a rig file).

    Returns
    -------
    AlphaFit
        α (1/K) with its 95 % interval, the residual rms (µm), the visits used and the
        residual of every visit.

    Raises
    ------
    TypeError
        ``tables`` is a single DataFrame or not a list of DataFrames; ``rig`` is not a rig.
    InputError
        No table, a table that is not a run table, or too few visits to fit α.

    Examples
    --------
    >>> import thermrs
    >>> rig = thermrs.load_rig()
    >>> t, _ = thermrs.fit.load_run_table("run1.parquet", rig)  # doctest: +SKIP
    >>> f = thermrs.fit.fit_alpha([t], rig)  # doctest: +SKIP
    >>> f.alpha_per_k, f.ci95  # doctest: +SKIP
    (2.19e-05, (2.17e-05, 2.21e-05))
    """
    tables = check_tables(tables)
    rig = as_rig(rig)
    table = pl.concat(tables, how="diagonal_relaxed")
    if table.height < 3:
        raise InputError(f"{table.height} visits: too few to fit α")
    d = alpha_design(table, rig)
    x, y, ok, n = d.x, d.y, d.ok, table.height
    dof = len(y) - x.shape[1]
    if dof < 1:
        raise InputError(f"{len(y)} measurements for {x.shape[1]} parameters: too few to fit α")
    try:
        # Feasible weighted least squares: an ordinary fit, then every (camera, axis) weighted
        # by the inverse of its own residual variance (pose repeatability and centroid noise
        # project differently onto the chips' axes), refitted with the autocorrelation-aware
        # covariance (see the module docstring).
        w = _noise_weights(lstsq_qr(x, y).residuals, d.noise, dof)
        fit = lstsq_qr(
            x, y, w, covariance="hac", series=d.series, units=d.unit, order=d.order, prewhiten=True
        )
    except ValueError as e:
        raise InputError(f"cannot fit α: {e}") from None
    se = float(fit.stderr()[0])
    a = float(fit.coef[0])
    lo, hi = fit.interval(0)
    r = fit.residuals
    full = np.full(2 * n, np.nan)
    full[ok] = r
    res = table.select("run", "camera", "visit", "t_ns").with_columns(
        residual_u_um=pl.Series(full[:n]), residual_v_um=pl.Series(full[n:])
    )
    return AlphaFit(
        alpha_per_k=a,
        ci95=(lo, hi),
        rms_um=float(np.sqrt(np.mean(r**2))),
        n_visits=n,
        residuals=res,
        stderr=se,
        interval=f"Student-t ({fit.t_dof:.1f} dof) on the {fit.method}",
        n_eff=fit.n_eff,
        ar1=float(fit.ar1[0]),
    )


@dataclass(frozen=True)
class AlphaDesign:
    """The α-plus-offsets least-squares problem of a run table: rows every visit's u then v
    (non-finite ones dropped, ``ok``), columns α then an offset per (run, camera) and axis;
    per row its noise group (camera, axis), unit (the visit) and series (run, camera), and
    time order."""

    x: np.ndarray
    y: np.ndarray
    ok: np.ndarray
    noise: np.ndarray
    series: np.ndarray
    unit: np.ndarray
    order: np.ndarray


def alpha_design(table: pl.DataFrame, rig: RigLike) -> AlphaDesign:
    """The least-squares problem :func:`fit_alpha` solves for a run table (also used by
    ``benchmarks/bench_coverage.py``, so that its comparisons fit the same design)."""
    su, sv = sensitivities(table, rig)
    groups = table.select(pl.concat_str(["run", "camera"], separator="/")).to_series()
    keys = sorted(set(groups.to_list()))
    g = np.array([keys.index(k) for k in groups.to_list()])
    n, k = table.height, len(keys)
    # Rows: every visit's u then v. Columns: α, then offsets (group, axis).
    x = np.zeros((2 * n, 1 + 2 * k))
    x[:n, 0], x[n:, 0] = su, sv
    x[np.arange(n), 1 + g] = 1.0
    x[n + np.arange(n), 1 + k + g] = 1.0
    y = np.concatenate([table["u_um"].to_numpy(), table["v_um"].to_numpy()])
    ok = np.isfinite(y) & np.isfinite(x[:, 0])
    x, y = x[ok], y[ok]
    x = x[:, np.any(x != 0, axis=0) | (np.arange(x.shape[1]) == 0)]  # offsets with no row
    cams = np.asarray(table["camera"].to_list(), dtype=object)
    gkey = np.asarray(groups.to_list(), dtype=object)
    axis = np.repeat(np.array(["/u", "/v"], dtype=object), n)
    t_ns = table["t_ns"].to_numpy()
    return AlphaDesign(
        x=x,
        y=y,
        ok=ok,
        noise=(np.concatenate([cams, cams]) + axis)[ok],
        series=np.concatenate([gkey, gkey])[ok],
        unit=np.concatenate([np.arange(n), np.arange(n)])[ok],
        order=np.concatenate([t_ns, t_ns]).astype(np.float64)[ok],
    )


def _noise_weights(r0: np.ndarray, noise: np.ndarray, dof: int) -> np.ndarray:
    """Per row the inverse of its noise group's residual variance (the pooled one for a
    group of fewer than five rows), scaled to a median of one."""
    w = np.empty(len(r0))
    pooled = float(r0 @ r0) / dof
    for grp in set(noise.tolist()):
        m = noise == grp
        var = float(np.mean(r0[m] ** 2)) if m.sum() >= 5 else pooled
        w[m] = 1.0 / max(var, 1e-12 * max(pooled, 1e-300))
    w /= float(np.median(w))
    return w


@dataclass(frozen=True)
class StartEndFit:
    """The paper's start/end estimator, per camera and their mean (see
    :func:`fit_alpha_start_end`)."""

    per_camera: dict[str, tuple[float, tuple[float, float]]]
    mean: tuple[float, tuple[float, float]]
    visit_noise_um: float
    #: The chip axis each camera's α was taken along.
    axes: dict[str, str] = field(default_factory=dict)

    def to_json(self) -> dict[str, object]:
        """``{"per_camera": {camera: {"value", "ci95"}}, "mean": {…}, "visit_noise_um"}``."""

        def one(v: tuple[float, tuple[float, float]]) -> dict[str, object]:
            return {"value": v[0], "ci95": list(v[1])}

        return {
            "per_camera": {
                c: {**one(v), "axis": self.axes.get(c)} for c, v in self.per_camera.items()
            },
            "mean": one(self.mean),
            "visit_noise_um": self.visit_noise_um,
        }


def fit_alpha_start_end(
    table: pl.DataFrame,
    rig: RigLike,
    *,
    axis: str = "auto",
    visit_noise_um: float | None = None,
    temperature_noise_c: float = 0.05,
) -> StartEndFit:
    """The paper's estimator (Eq. 2 with the forward model in place of Eq. 3): per camera,
    α = (drift between the run's first and last visit along the chip ``axis``) / (the same
    drift per unit α predicted from the temperatures at those two visits); the mean of the
    cameras.

    ``axis`` is ``"u"``, ``"v"`` or ``"auto"`` (default: per camera, the axis along which the
    forward model predicts the larger drift; the paper measured along its cameras' y axis,
    which on the SPEC rig is v, but at its poses the links' expansion moves the spot mostly
    along u).

    Its interval propagates the errors of the two visits used: the spot's noise (±√2·noise/|Δs|;
    ``visit_noise_um`` gives it, by default the residual RMS of the time-series fit
    :func:`fit_alpha` on the same table for that camera and axis, which includes pose
    repeatability) and the error of each mapped temperature reading at those two visits,
    ``temperature_noise_c`` (default 0.05 K: an IR camera's pixel noise class, and the first
    visit of a run usually precedes its first thermal frame, so its temperature is
    extrapolated), through the model's sensitivity to each temperature. Two visits carry
    no information about either error, so both are inputs, not estimates; the time-series
    estimator needs neither. The two visits are far apart, so the spot errors enter with
    their full (marginal) variance whatever their autocorrelation. The mean's interval treats
    the cameras' spot errors as independent and a temperature reading's error as common to
    every camera (their first, and their last, visits read the same thermal frames).

    Parameters
    ----------
    table
        One run's table (:func:`run_table`).
    rig
        The rig (a :class:`~thermrs.Rig` or the path of a rig file).
    axis
        ``"u"``, ``"v"`` or ``"auto"`` (see above).
    visit_noise_um
        The noise of one visit's spot (µm); default from :func:`fit_alpha`'s residuals.
    temperature_noise_c
        The error of one mapped temperature reading (K).

    Returns
    -------
    StartEndFit
        α per camera and their mean, each with a 95 % interval, and the visit noise used.

    Raises
    ------
    TypeError
        ``table`` is not a polars DataFrame (e.g. a list of tables); ``rig`` is not a rig.
    InputError
        Bad ``axis``; no camera with two visits; no predicted drift between them.

    Examples
    --------
    >>> import thermrs
    >>> rig = thermrs.load_rig()
    >>> t, _ = thermrs.fit.load_run_table("run1.parquet", rig)  # doctest: +SKIP
    >>> se = thermrs.fit.fit_alpha_start_end(t, rig)  # doctest: +SKIP
    >>> se.per_camera["A"][0], se.mean  # doctest: +SKIP
    """
    if not isinstance(table, pl.DataFrame):
        raise TypeError(
            f"table must be one run table (polars DataFrame), not {type(table).__name__}"
        )
    check_tables([table], what="table")
    rig = as_rig(rig)
    if axis not in ("u", "v", "auto"):
        raise InputError(f"axis must be 'u', 'v' or 'auto', got {axis!r}")
    su, sv = sensitivities(table, rig)
    # Sensitivity of (su, sv) to one kelvin on each mapped temperature.
    grads = []
    for n in ForwardModel(rig).temperature_names:
        gu, gv = sensitivities(table.with_columns(pl.col(f"{n}_c") + 1.0), rig)
        grads.append((gu - su, gv - sv))
    res = fit_alpha([table], rig).residuals if visit_noise_um is None else None
    cams = {}
    for cam in sorted(set(table["camera"].to_list())):
        one = _camera_start_end(table, cam, (su, sv), grads, axis, res, visit_noise_um)
        if one is not None:
            cams[cam] = one
    if not cams:
        raise InputError("no camera has two visits: nothing to estimate")
    return _combined(cams, temperature_noise_c)


@dataclass(frozen=True)
class _CameraStartEnd:
    """One camera's start/end α, the variance its spot noise gives it, and its derivative by
    each mapped temperature reading (``(temperature index, "first" | "last")``)."""

    alpha: float
    spot_var: float
    noise: float
    dtemp: dict[tuple[int, str], float]
    axis: str = "u"


def _camera_start_end(
    table: pl.DataFrame,
    cam: str,
    s: tuple[np.ndarray, np.ndarray],
    grads: list[tuple[np.ndarray, np.ndarray]],
    axis: str,
    res: pl.DataFrame | None,
    visit_noise_um: float | None,
) -> _CameraStartEnd | None:
    """α of ``cam`` from its first and last visit (None with fewer than two visits)."""
    idx = np.flatnonzero((table["camera"] == cam).to_numpy())
    idx = idx[np.argsort(table["t_ns"].to_numpy()[idx])]
    if len(idx) < 2:
        return None
    first, last = idx[0], idx[-1]
    su, sv = s
    ax = axis
    if ax == "auto":
        ax = "u" if abs(su[last] - su[first]) >= abs(sv[last] - sv[first]) else "v"
    sens = su if ax == "u" else sv
    y = table[f"{ax}_um"].to_numpy()
    ds = sens[last] - sens[first]
    if ds == 0:
        raise InputError(f"camera {cam}: no predicted drift between first and last visit")
    if visit_noise_um is not None:
        noise = float(visit_noise_um)
    else:
        assert res is not None
        r = res.filter(pl.col("camera") == cam)[f"residual_{ax}_um"].to_numpy()
        noise = float(np.sqrt(np.nanmean(r**2)))
    a = (y[last] - y[first]) / ds
    k = 0 if ax == "u" else 1
    dtemp = {
        (j, end): sign * a * g[k][i] / ds
        for j, g in enumerate(grads)
        for end, i, sign in (("first", first, 1.0), ("last", last, -1.0))
    }
    return _CameraStartEnd(
        alpha=a, spot_var=2.0 * noise**2 / ds**2, noise=noise, dtemp=dtemp, axis=ax
    )


def _combined(cams: dict[str, _CameraStartEnd], temperature_noise_c: float) -> StartEndFit:
    """Each camera's α with its 95 % interval (its spots' and its temperatures' variance), and
    their mean with its own (:func:`fit_alpha_start_end`)."""
    per: dict[str, tuple[float, tuple[float, float]]] = {}
    # ∂α_c/∂T per (mapped temperature, first or last visit): the cameras' first (last) visits
    # lie in one cycle and read the same thermal frames, so a reading error is common to all
    # cameras and enters their mean coherently, not independently.
    dtemp: dict[tuple[int, str], list[float]] = {}
    for cam, one in cams.items():
        temp_var = 0.0
        for key, d in one.dtemp.items():
            temp_var += (d * temperature_noise_c) ** 2
            dtemp.setdefault(key, []).append(d)
        half = 1.96 * np.sqrt(one.spot_var + temp_var)
        per[cam] = (float(one.alpha), (float(one.alpha - half), float(one.alpha + half)))
    c = len(per)
    m = float(np.mean([v[0] for v in per.values()]))
    var_m = float(np.sum([one.spot_var for one in cams.values()])) / c**2 + sum(
        (sum(d) / c * temperature_noise_c) ** 2 for d in dtemp.values()
    )
    half_m = 1.96 * float(np.sqrt(var_m))
    noise = float(np.sqrt(np.mean(np.square([one.noise for one in cams.values()]))))
    return StartEndFit(
        per_camera=per,
        mean=(m, (m - half_m, m + half_m)),
        visit_noise_um=noise,
        axes={cam: one.axis for cam, one in cams.items()},
    )


@dataclass(frozen=True)
class FitResult:
    """α fitted on training runs, both estimators (see :func:`fit_document`)."""

    fit: AlphaFit
    start_end: dict[str, StartEndFit]

    def to_json(self) -> dict[str, Any]:
        """The ``thermrs fit --json`` document: the time-series fit with ``start_end`` per run."""
        doc = self.fit.to_json()
        doc["start_end"] = {run: se.to_json() for run, se in self.start_end.items()}
        return doc


def fit_document(tables: Sequence[pl.DataFrame], rig: RigLike) -> FitResult:
    """Fit α over ``tables`` (time series) and per table with the paper's start/end estimator:
    what ``thermrs fit`` reports.

    Parameters
    ----------
    tables
        The training run tables.
    rig
        The rig they were recorded on.

    Returns
    -------
    FitResult
        The time-series fit and the start/end fit per run (``to_json()``: the ``thermrs fit
        --json`` document).

    Raises
    ------
    InputError
        Too few visits, or a table that is not a run table (see :func:`fit_alpha`).

    Examples
    --------
    >>> res = fit_document(load_runs("rec.mcap#run1", rig).tables, rig)  # doctest: +SKIP
    >>> res.fit.alpha_per_k, res.start_end["rec#run1"].mean  # doctest: +SKIP
    """
    f = fit_alpha(tables, rig)
    return FitResult(f, {str(t["run"][0]): fit_alpha_start_end(t, rig) for t in tables})


def training_alphas(result: FitResult) -> dict[str, float]:
    """The labelled α values a prediction from the training runs uses: ``series`` (the
    time-series fit) and, with one training run (the paper's protocol), its start/end α per
    camera and their ``mean``.

    Parameters
    ----------
    result
        :func:`fit_document` of the training runs.

    Returns
    -------
    dict
        Label → α (1/K).

    Raises
    ------
    KeyError
        Never for a :func:`fit_document` result.

    Examples
    --------
    >>> training_alphas(fit_document(tables, rig))  # doctest: +SKIP
    {'series': …, 'A': 2.187e-05, 'B': 2.163e-05, 'mean': 2.175e-05}
    """
    alphas = {"series": result.fit.alpha_per_k}
    if len(result.start_end) == 1:  # the paper's protocol: α per camera and their mean
        se = next(iter(result.start_end.values()))
        for cam, (a, _) in se.per_camera.items():
            alphas[cam] = a
        alphas["mean"] = se.mean[0]
    return alphas


def training_axes(result: FitResult) -> dict[str, str]:
    """The chip axis each camera's start/end α was taken along (the paper's protocol: one
    training run), by camera: its Table 7 rows are judged along that axis.

    Parameters
    ----------
    result
        :func:`fit_document` of the training runs.

    Returns
    -------
    dict
        Camera → ``"u"`` or ``"v"``; empty with several training runs.

    Raises
    ------
    KeyError
        Never for a :func:`fit_document` result.

    Examples
    --------
    >>> training_axes(fit_document(tables, rig))  # doctest: +SKIP
    {'A': 'v', 'B': 'v'}
    """
    if len(result.start_end) != 1:
        return {}
    return dict(next(iter(result.start_end.values())).axes)
