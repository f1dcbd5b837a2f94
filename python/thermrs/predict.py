"""Prediction: a run's drift from its temperatures and an α fitted on other runs.

Forward model (SPEC §4)
    For every visit of a run table (:func:`thermrs.fit.run_table`), the spot's displacement on
    the camera's chip from the camera's first visit of the run, computed with the rig's
    kinematics, links expanded by α at the visit's mapped temperatures, the laser ray and the
    chip: both chip axes, any rig, any pose.

Paper projection (SPEC §5, Eq. 3)
    Δl = α·(l₂·cos 17.55°·ΔT₂ + l₃·cos 55.57°·ΔT₃)·cos φ·cos θ along the camera's y axis, with
    ΔT from the run's first visit; only where the paper's data name the camera (φ, θ) and the
    run table has ``link2_c`` and ``link3_c``.

Comparison with the measurement
    Measured drift is anchored at the first visit (SPEC §4), so that visit's noise is in every
    measured value; ``rms_um`` compares anchored series, ``rms_centred_um`` removes the mean
    difference first (what is left is the model's error plus each visit's own noise). The noise
    level of the measurement itself, ``noise_um``, is estimated from the measured series alone
    from its successive differences, which a slow drift hardly touches, allowing for noise
    that is autocorrelated from visit to visit (:func:`noise_um`; the von Neumann estimator
    when it is white): that is the floor a perfect model reaches.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt
import polars as pl

from thermrs.errors import InputError
from thermrs.fit import FitResult, RigLike, check_tables, sensitivities
from thermrs.paper import PaperData, load_paper_data, predicted_dl_um
from thermrs.rig import as_rig

__all__ = [
    "MAX_ALPHA_PER_K",
    "HeldOut",
    "check_alpha",
    "noise_um",
    "predict",
    "predict_held_out",
    "prediction_table",
]

#: No solid expands by 1/1000 per kelvin (metals 1e-5 to 3e-5, polymers up to 2e-4): an α
#: this large is a value given in other units (23.2 meaning 23.2 × 10⁻⁶ /K).
MAX_ALPHA_PER_K = 1e-3


def check_alpha(alpha_per_k: float, *, what: str = "alpha_per_k", positive: bool = False) -> float:
    """``alpha_per_k`` as a float if it can be a thermal expansion coefficient (1/K).

    Parameters
    ----------
    alpha_per_k
        The value to check.
    what
        How messages name it (e.g. ``"--alpha"``).
    positive
        Also reject α ≤ 0 (a given α; a fitted one may come out ≤ 0 on noise).

    Returns
    -------
    float
        The value.

    Raises
    ------
    InputError
        Not a finite number, ``|α| ≥`` :data:`MAX_ALPHA_PER_K` (the message suggests the value
        × 10⁻⁶), or ≤ 0 with ``positive``.

    Examples
    --------
    >>> from thermrs.predict import check_alpha
    >>> check_alpha(23.2e-6)
    2.32e-05
    >>> check_alpha(23.2)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    thermrs._native.InputError: alpha_per_k 23.2 /K is not ...; for 23.2 × 10⁻⁶ /K write 23.2e-6
    """
    try:
        a = float(alpha_per_k)
    except (TypeError, ValueError):
        raise InputError(f"{what} must be a number (1/K), got {alpha_per_k!r}") from None
    if not np.isfinite(a):
        raise InputError(f"{what} must be finite, got {a}")
    if positive and a <= 0:
        raise InputError(f"{what} must be > 0 (1/K), got {a:g}")
    if abs(a) >= MAX_ALPHA_PER_K:
        raise InputError(
            f"{what} {a:g} /K is not a thermal expansion coefficient (solids: 1e-6 to 2e-4 /K)"
            + (f"; for {abs(a):g} × 10⁻⁶ /K write {abs(a):g}e-6" if abs(a) < 1e3 else "")
        )
    return a


def noise_um(values: npt.ArrayLike) -> float:
    """The noise level (standard deviation) of a slowly varying series whose noise may be
    autocorrelated from sample to sample. NaN with fewer than three finite values.

    Successive differences d = Δy remove a slow drift. For white noise of variance σ², d has
    variance 2σ² (von Neumann); for AR(1) noise with coefficient ρ, 2σ²(1−ρ), and the lag-1
    autocorrelation of d is −(1−ρ)/2. So ρ̂ = 1 + 2·r₁(d) (clipped to [0, 0.95]) and
    σ̂² = var(d)/(2(1−ρ̂)): the von Neumann estimator when the noise is white, and the
    noise's full (marginal) level, not only its fast part, when it is not.

    Parameters
    ----------
    values
        The series; non-finite values are dropped.

    Returns
    -------
    float
        The noise's standard deviation; NaN with fewer than three finite values.

    Raises
    ------
    ValueError
        ``values`` cannot be read as numbers.

    Examples
    --------
    >>> import numpy as np
    >>> from thermrs.predict import noise_um
    >>> x = np.random.default_rng(0).normal(0.0, 0.5, 100_000) + np.linspace(0, 10, 100_000)
    >>> round(noise_um(x), 2)
    0.5
    """
    v = np.asarray(values, dtype=np.float64)
    v = v[np.isfinite(v)]
    if len(v) < 3:
        return float("nan")
    d = np.diff(v)
    d = d - d.mean()
    var = float(np.mean(d**2))
    if var <= 0:
        return 0.0
    r1 = float(d[1:] @ d[:-1]) / (var * len(d)) if len(d) >= 3 else -0.5
    rho = min(max(1.0 + 2.0 * r1, 0.0), 0.95)
    return float(np.sqrt(var / (2.0 * (1.0 - rho))))


def predict(
    table: pl.DataFrame,
    rig: RigLike,
    *,
    alpha_per_k: float,
    paper: PaperData | None = None,
) -> pl.DataFrame:
    """Predicted drift of every visit of ``table`` beside the measured one.

    Parameters
    ----------
    table
        Run table(s) (:func:`thermrs.fit.run_table`); several runs may be concatenated.
    rig
        The rig the runs were recorded on (a :class:`~thermrs.Rig` or the path of a rig file).
    alpha_per_k
        The expansion coefficient (1/K), e.g. fitted on training runs (``21.75e-6``, not
        ``21.75``).
    paper
        The paper's Eq. 3 data (default: the embedded tables) for the ``paper_v_um`` column.

    Returns
    -------
    polars.DataFrame
        ``run``, ``camera``, ``visit``, ``t_ns``, ``measured_u_um``, ``measured_v_um``,
        ``predicted_u_um``, ``predicted_v_um``, ``residual_u_um``, ``residual_v_um``
        (measured − predicted) and ``paper_v_um`` (Eq. 3 along the camera's y axis; null where
        it does not apply). Every drift is anchored at the camera's first visit of its run.

    Raises
    ------
    TypeError
        ``table`` is not a polars DataFrame; ``rig`` is not a rig.
    InputError
        ``alpha_per_k`` is not finite or not a plausible α (see :func:`check_alpha`); the
        table is not a run table or has no visits.

    Examples
    --------
    >>> import thermrs
    >>> rig = thermrs.load_rig()
    >>> t, _ = thermrs.fit.load_run_table("run2.parquet", rig)  # doctest: +SKIP
    >>> p = thermrs.predict.predict(t, rig, alpha_per_k=21.75e-6)  # doctest: +SKIP
    >>> p.select("camera", "predicted_v_um", "measured_v_um").tail(1)  # doctest: +SKIP
    """
    if not isinstance(table, pl.DataFrame):
        raise TypeError(f"table must be a run table (polars DataFrame), not {type(table).__name__}")
    alpha_per_k = check_alpha(alpha_per_k)
    rig = as_rig(rig)
    if table.height == 0:
        raise InputError("the run table has no visits to predict")
    t = table.sort("run", "camera", "t_ns")
    su, sv = sensitivities(t, rig)
    key = t.select(pl.concat_str(["run", "camera"], separator="/")).to_series().to_numpy()
    first = np.zeros(t.height, dtype=np.int64)
    for k in np.unique(key):
        idx = np.flatnonzero(key == k)
        first[idx] = idx[0]
    pu = alpha_per_k * (su - su[first])
    pv = alpha_per_k * (sv - sv[first])
    mu = t["u_um"].to_numpy() - t["u_um"].to_numpy()[first]
    mv = t["v_um"].to_numpy() - t["v_um"].to_numpy()[first]
    d = load_paper_data() if paper is None else paper
    paper_v = np.full(t.height, np.nan)
    if "link2_c" in t.columns and "link3_c" in t.columns:
        t2 = t["link2_c"].to_numpy()
        t3 = t["link3_c"].to_numpy()
        cams = t["camera"].to_numpy()
        for i in range(t.height):
            if cams[i] in d.cameras:
                paper_v[i] = predicted_dl_um(
                    alpha_per_k,
                    str(cams[i]),
                    float(t2[i] - t2[first[i]]),
                    float(t3[i] - t3[first[i]]),
                    data=d,
                )
    return t.select("run", "camera", "visit", "t_ns").with_columns(
        measured_u_um=pl.Series(mu),
        measured_v_um=pl.Series(mv),
        predicted_u_um=pl.Series(pu),
        predicted_v_um=pl.Series(pv),
        residual_u_um=pl.Series(mu - pu),
        residual_v_um=pl.Series(mv - pv),
        paper_v_um=pl.Series(paper_v).fill_nan(None),
    )


def prediction_table(
    tables: Sequence[pl.DataFrame],
    rig: RigLike,
    *,
    alphas: Mapping[str, float],
    axis: str = "auto",
    end_visits: int = 1,
    camera_axes: Mapping[str, str] | None = None,
) -> pl.DataFrame:
    """A Table 7-style table for any runs and cameras: per α (label → value), camera and run,
    the predicted and measured drift at the end of the run and the % error, with the whole
    series' agreement beside it.

    Parameters
    ----------
    tables
        Run tables of the runs to predict (usually held out from the fit); a list even for
        one run.
    rig
        The rig (a :class:`~thermrs.Rig` or the path of a rig file).
    alphas
        Labelled α values (1/K), e.g. ``{"A": …, "B": …, "mean": …}`` or ``{"fit": …}``.
    axis
        Chip axis of the end-of-run figures: ``"u"``, ``"v"``, or ``"auto"`` (default: the axis
        along which the forward model predicts the larger drift for that camera and run).
    end_visits
        The end of the run is the mean of the last ``end_visits`` visits (default 1: the last
        visit, as the paper).
    camera_axes
        With ``axis="auto"``: the axis to use per camera where one is given (the axis its
        start/end α was taken along, :func:`thermrs.analyses.fit.training_axes`).

    Returns
    -------
    polars.DataFrame
        ``alpha`` (label), ``alpha_per_k``, ``camera``, ``run``, ``axis``, ``predicted_um``,
        ``measured_um``, ``error_pct`` ((predicted − measured)/measured·100), ``rms_um`` and
        ``rms_centred_um`` (prediction against measurement over every visit, both axes),
        ``noise_um`` (the measurement's own noise, von Neumann, both axes), ``n_visits``.

    Raises
    ------
    TypeError
        ``tables`` is a single DataFrame or not a list of DataFrames; ``rig`` is not a rig.
    InputError
        No table, a table that is not a run table, bad ``axis`` or ``end_visits``, no α, or
        an α that is not plausible (:func:`check_alpha`).

    Examples
    --------
    >>> import thermrs
    >>> rig = thermrs.load_rig()
    >>> t, _ = thermrs.fit.load_run_table("run2.parquet", rig)  # doctest: +SKIP
    >>> thermrs.predict.prediction_table([t], rig, alphas={"A": 21.87e-6})  # doctest: +SKIP
    """
    tables = check_tables(tables)
    rig = as_rig(rig)
    if axis not in ("u", "v", "auto"):
        raise InputError(f"axis must be 'u', 'v' or 'auto', got {axis!r}")
    if end_visits < 1:
        raise InputError(f"end_visits must be ≥ 1, got {end_visits}")
    if not alphas:
        raise InputError("no α to predict with")
    table = pl.concat(list(tables), how="diagonal_relaxed")
    rows: list[dict[str, object]] = []
    for label, alpha in alphas.items():
        p = predict(table, rig, alpha_per_k=alpha)
        for (_, cam), g in p.group_by(["run", "camera"], maintain_order=True):
            ax = camera_axes.get(str(cam), axis) if axis == "auto" and camera_axes else axis
            rows.append(_row(g.sort("t_ns"), label, alpha, ax, end_visits))
    return pl.DataFrame(rows)


def _row(g: pl.DataFrame, label: str, alpha: float, ax: str, end_visits: int) -> dict[str, object]:
    """One camera's row in one run (``g``, predicted with ``alpha``, in time order) of
    :func:`prediction_table`, along ``ax`` (``auto``: the axis of the larger predicted end
    drift)."""
    run, cam = g["run"][0], g["camera"][0]
    pred = {a: g[f"predicted_{a}_um"].to_numpy() for a in "uv"}
    meas = {a: g[f"measured_{a}_um"].to_numpy() for a in "uv"}
    if ax == "auto":
        ax = "u" if abs(pred["u"][-1]) >= abs(pred["v"][-1]) else "v"
    k = min(end_visits, g.height)
    pe = float(np.mean(pred[ax][-k:]))
    me = float(np.mean(meas[ax][-k:]))
    res = np.concatenate([meas["u"] - pred["u"], meas["v"] - pred["v"]])
    res = res[np.isfinite(res)]
    centred = np.concatenate(
        [
            (meas[a] - pred[a]) - np.nanmean(meas[a] - pred[a])
            for a in "uv"
            if np.isfinite(meas[a] - pred[a]).any()
        ]
    )
    noise = np.sqrt(np.nanmean([noise_um(meas["u"]) ** 2, noise_um(meas["v"]) ** 2]))
    return {
        "alpha": label,
        "alpha_per_k": float(alpha),
        "camera": cam,
        "run": run,
        "axis": ax,
        "predicted_um": pe,
        "measured_um": me,
        "error_pct": (pe - me) / me * 100.0 if me != 0 else float("nan"),
        "rms_um": float(np.sqrt(np.mean(res**2))) if len(res) else float("nan"),
        "rms_centred_um": float(np.sqrt(np.nanmean(centred**2))),
        "noise_um": float(noise),
        "n_visits": g.height,
    }


@dataclass(frozen=True)
class HeldOut:
    """Held-out runs predicted with α fitted on training runs or given
    (:func:`predict_held_out`).

    Attributes
    ----------
    alphas
        The α values predicted with, by label (:func:`thermrs.fit.training_alphas`, or the α
        given).
    table
        :func:`prediction_table` of the held-out runs.
    series
        Every held-out visit's predicted and measured drift, per α (``alpha`` column: label).
    fit
        The fit on the training runs (``None`` where α was given).
    """

    alphas: dict[str, float]
    table: pl.DataFrame
    series: pl.DataFrame
    fit: FitResult | None = None


def predict_held_out(
    train: Sequence[pl.DataFrame],
    holdout: Sequence[pl.DataFrame],
    rig: Any,
    *,
    alphas: Mapping[str, float] | None = None,
    axis: str = "auto",
    end_visits: int = 1,
) -> HeldOut:
    """The held-out runs predicted with ``alphas`` or, without, with the α values fitted on the
    training runs (:func:`thermrs.fit.fit_document`, :func:`thermrs.fit.training_alphas`):
    what ``thermrs predict`` and the report's prediction both compute.

    Parameters
    ----------
    train
        The training run tables (unused with ``alphas``).
    holdout
        The run tables to predict.
    rig
        The rig they were recorded on.
    alphas
        α values (1/K) by label to predict with instead of fitting.
    axis, end_visits
        As :func:`prediction_table`.

    Returns
    -------
    HeldOut
        The α values, the Table 7-style table and every visit's series.

    Raises
    ------
    InputError
        Too few visits to fit (:func:`thermrs.fit.fit_alpha`), no held-out run, a bad α.

    Examples
    --------
    >>> p = predict_held_out(runs.tables[:1], runs.tables[1:], rig)  # doctest: +SKIP
    >>> p.alphas["series"], p.table  # doctest: +SKIP
    """
    from thermrs.fit import fit_document, training_alphas, training_axes

    doc = None if alphas else fit_document(train, rig)
    a = training_alphas(doc) if doc is not None else dict(alphas or {})
    axes = {} if doc is None else training_axes(doc)
    table = prediction_table(
        holdout, rig, alphas=a, axis=axis, end_visits=end_visits, camera_axes=axes
    )
    joined = pl.concat(holdout, how="diagonal_relaxed")
    series = pl.concat(
        [
            predict(joined, rig, alpha_per_k=v).select(pl.lit(k).alias("alpha"), pl.all())
            for k, v in a.items()
        ]
    )
    return HeldOut(a, table, series, doc)
