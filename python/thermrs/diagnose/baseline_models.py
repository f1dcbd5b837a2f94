"""The regressions thermrs sets beside the physical model: their features (temperatures,
low-pass filtered temperatures, time since the run began), their cross-validation by run and
their fits with scikit-learn (:mod:`thermrs.diagnose.baselines` scores them)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt
import polars as pl

from thermrs.errors import InputError

__all__ = [
    "DESCRIPTIONS",
    "DRAWS",
    "LOWPASS_TAUS_MIN",
    "MODELS",
    "Features",
    "FittedBaseline",
    "cv_folds",
    "features",
    "fit_baseline",
    "lowpass",
]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]

#: The baselines, in the order they are reported.
MODELS = ("ols", "ridge", "lowpass_ols", "lowpass_ridge", "lowpass_lasso", "gbt")
#: What each is, in a few words (the table and the JSON say it).
DESCRIPTIONS = {
    "ols": "least squares on the temperatures",
    "ridge": "ridge on the temperatures (penalty by CV)",
    "lowpass_ols": "least squares on low-pass temperatures and time",
    "lowpass_ridge": "ridge on low-pass temperatures and time (penalty by CV)",
    "lowpass_lasso": "LASSO on low-pass temperatures and time (penalty by CV)",
    "gbt": "gradient-boosted trees on low-pass temperatures and time",
}
#: Time constants (min) of the low-pass filtered temperatures.
LOWPASS_TAUS_MIN = (10.0, 30.0, 90.0)
#: Contiguous blocks a single training run is cut into for cross-validation.
SINGLE_RUN_BLOCKS = 5
#: Ridge penalties tried (on standardised features).
RIDGE_ALPHAS = tuple(float(a) for a in np.logspace(-3, 4, 15))
#: Bootstrap draws of the intervals.
DRAWS = 999


# --- features ---------------------------------------------------------------------------------


def lowpass(t_s: FloatArray, x: FloatArray, tau_s: float) -> FloatArray:
    """``x`` (samples × columns) through a first-order low-pass filter of time constant
    ``tau_s``, sampled at the times ``t_s`` (s, increasing), starting at equilibrium with the
    first sample: y₀ = x₀, yₖ = xₖ + (yₖ₋₁ − xₖ)·e^(−Δtₖ/τ) (the input held at xₖ over
    the step, exact for any spacing)."""
    x = np.asarray(x, dtype=np.float64)
    y = np.empty_like(x)
    if len(x) == 0:
        return y
    decay = np.exp(-np.diff(np.asarray(t_s, dtype=np.float64)) / tau_s)
    y[0] = x[0]
    for k in range(1, len(x)):
        y[k] = x[k] + (y[k - 1] - x[k]) * decay[k - 1]
    return y


@dataclass(frozen=True)
class Features:
    """Every visit's drift and regressors (rows: the visits of :attr:`visits`, sorted by run,
    camera and time).

    Attributes
    ----------
    visits
        The visits (:class:`thermrs.signatures.VisitSet`, temperatures de-noised).
    temperatures
        The temperature names regressed on (ROI names and ``ambient``).
    raw
        The temperatures relative to the run's first visit of the camera (n × k, K).
    lowpass, lowpass_names
        The low-pass temperatures relative to that visit and the hours since the run began
        (n × (k·len(taus) + 1)), and their names.
    drift
        The spot relative to that visit (n × 2: u, v, µm).
    first_c
        The first visit's temperatures (n × k, °C: what the law's ΔT is relative to).
    smoothed
        Whether the temperatures were de-noised as the diagnosis de-noises them.
    """

    visits: Any
    temperatures: list[str]
    raw: FloatArray
    lowpass: FloatArray
    lowpass_names: list[str]
    drift: FloatArray
    first_c: FloatArray
    smoothed: bool = True

    def matrix(self, model: str) -> FloatArray:
        """The regressors ``model`` uses."""
        return self.raw if model in ("ols", "ridge") else self.lowpass

    def names(self, model: str) -> list[str]:
        """Their names."""
        return (
            [f"d_{t}" for t in self.temperatures]
            if model in ("ols", "ridge")
            else list(self.lowpass_names)
        )


def features(
    tables: Sequence[pl.DataFrame],
    rig: Any,
    *,
    taus_min: Sequence[float] = LOWPASS_TAUS_MIN,
    smooth: bool = True,
) -> Features:
    """The drift and the regressors of run tables (module docs).

    Parameters
    ----------
    tables
        Run tables (training and held-out together: the de-noising uses the thermal time
        scales of all of them, as the diagnosis's does).
    rig
        The rig (a :class:`~thermrs.rig.Rig` or its file).
    taus_min
        Time constants of the low-pass features (minutes).
    smooth
        De-noise the temperatures as the diagnosis does.

    Raises
    ------
    InputError
        No temperature every visit carries.
    """
    from thermrs.diagnose.floor import SCALE_SEPARATION, thermal_time_scales
    from thermrs.diagnose.input_checks import smooth_temperatures
    from thermrs.rig import as_rig
    from thermrs.signatures import VisitSet

    r = as_rig(rig)
    raw_tables = list(tables)
    if smooth:
        taus, _ = thermal_time_scales(VisitSet(raw_tables, r), r.mapped_temperatures)
        half = 2.0 * min(taus.values()) * 60.0 / SCALE_SEPARATION
        raw_tables = smooth_temperatures(raw_tables, half)
    vs = VisitSet(raw_tables, r)
    names = sorted(vs.temps)
    if not names:
        raise InputError(
            "the runs carry no temperature measured at every visit: nothing to regress on"
        )
    temp = np.column_stack([vs.temps[k] for k in names])
    n = vs.n
    yu, yv = vs.y[:n], vs.y[n:]
    k = len(names)
    raw = np.empty((n, k))
    first = np.empty((n, k))
    low = np.empty((n, k * len(taus_min) + 1))
    drift = np.empty((n, 2))
    for g in vs.groups:
        t = vs.t_s[g]
        first[g] = temp[g[0]]
        raw[g] = temp[g] - temp[g[0]]
        for j, tau in enumerate(taus_min):
            lp = lowpass(t, temp[g], 60.0 * float(tau))
            low[g, j * k : (j + 1) * k] = lp - lp[0]
        low[g, -1] = vs.t_since_start[g] / 3600.0
        drift[g, 0] = yu[g] - yu[g[0]]
        drift[g, 1] = yv[g] - yv[g[0]]
    low_names = [f"lp{tau:g}min_{t}" for tau in taus_min for t in names] + ["hours"]
    return Features(vs, names, raw, low, low_names, drift, first, smooth)


# --- cross-validation -------------------------------------------------------------------------


def cv_folds(
    runs: npt.ArrayLike, t_s: npt.ArrayLike
) -> tuple[list[tuple[IntArray, IntArray]], str]:
    """Cross-validation folds of training visits that never split a run: each run left out
    in turn (:class:`~sklearn.model_selection.LeaveOneGroupOut`); a single run is cut into
    :data:`SINGLE_RUN_BLOCKS` contiguous blocks of time, each left out in turn.

    Parameters
    ----------
    runs
        Per visit, its run.
    t_s
        Per visit, its time (s).

    Returns
    -------
    folds, how
        (training indices, validation indices) per fold, and how they were made.
    """
    from sklearn.model_selection import LeaveOneGroupOut  # type: ignore[import-untyped]

    r = np.asarray(runs).astype(str)
    t = np.asarray(t_s, dtype=np.float64)
    uniq = np.unique(r)
    if len(uniq) >= 2:
        groups = r
        how = f"by run: each of the {len(uniq)} training runs left out in turn"
    else:
        order = np.argsort(t, kind="stable")
        blocks = np.empty(len(t), dtype=np.intp)
        blocks[order] = np.arange(len(t)) * SINGLE_RUN_BLOCKS // max(len(t), 1)
        groups = blocks.astype(str)
        how = (
            f"by contiguous blocks of the one training run: {SINGLE_RUN_BLOCKS} blocks of "
            "time, each left out in turn (never single visits)"
        )
    x = np.zeros((len(r), 1))
    folds = [
        (np.asarray(a, dtype=np.intp), np.asarray(b, dtype=np.intp))
        for a, b in LeaveOneGroupOut().split(x, groups=groups)
    ]
    return folds, how


# --- fitting ----------------------------------------------------------------------------------


def _estimator(model: str, folds: list[tuple[IntArray, IntArray]], seed: int) -> Any:
    from sklearn.ensemble import HistGradientBoostingRegressor  # type: ignore[import-untyped]
    from sklearn.linear_model import LassoCV, LinearRegression, Ridge  # type: ignore[import-untyped]
    from sklearn.model_selection import GridSearchCV
    from sklearn.pipeline import make_pipeline  # type: ignore[import-untyped]
    from sklearn.preprocessing import StandardScaler  # type: ignore[import-untyped]

    if model in ("ols", "lowpass_ols"):
        return LinearRegression()
    if model in ("ridge", "lowpass_ridge"):
        return GridSearchCV(
            make_pipeline(StandardScaler(), Ridge()),
            {"ridge__alpha": list(RIDGE_ALPHAS)},
            cv=folds,
            scoring="neg_mean_squared_error",
        )
    if model == "lowpass_lasso":
        return make_pipeline(
            StandardScaler(), LassoCV(cv=folds, max_iter=20_000, random_state=seed)
        )
    if model == "gbt":
        return HistGradientBoostingRegressor(
            max_iter=200,
            learning_rate=0.05,
            max_leaf_nodes=15,
            min_samples_leaf=10,
            early_stopping=False,
            random_state=seed,
        )
    raise ValueError(f"unknown baseline {model!r} (known: {', '.join(MODELS)})")


def _n_params(model: str, est: Any) -> int:
    """The fitted coefficients of one channel's law (module docs)."""
    if model == "gbt":
        preds = getattr(est, "_predictors", None)
        if preds is None:  # pragma: no cover - a scikit-learn without it: the most there can be
            return int(est.n_iter_ * est.max_leaf_nodes)
        return int(sum(p.get_n_leaf_nodes() for it in preds for p in it))
    final = est.best_estimator_ if hasattr(est, "best_estimator_") else est
    if hasattr(final, "steps"):
        final = final.steps[-1][1]
    coef = np.ravel(final.coef_)
    if model in ("ols", "lowpass_ols"):
        return int(coef.size)
    return int(np.count_nonzero(coef)) + 1


@dataclass
class FittedBaseline:
    """One baseline fitted on the training runs: an estimator per (camera, axis).

    Attributes
    ----------
    name
        One of :data:`MODELS`.
    estimators
        ``{(camera, axis): fitted estimator}``.
    feature_names
        The regressors, in the estimators' column order.
    n_params
        Fitted parameters, summed over the channels (module docs).
    cv
        How its penalty was cross-validated (``None`` where there is none).
    penalties
        The chosen penalty per ``camera/axis`` (ridge and LASSO).
    train_range_c
        Per temperature, the range (°C) the training runs covered.
    """

    name: str
    estimators: dict[tuple[str, str], Any]
    feature_names: list[str]
    n_params: int
    cv: str | None
    penalties: dict[str, float] = field(default_factory=dict)
    train_range_c: dict[str, list[float]] = field(default_factory=dict)

    def predict(self, feats: Features) -> FloatArray:
        """The predicted drift of every visit (n × 2: u, v, µm; NaN for a camera it has no
        law for)."""
        x = feats.matrix(self.name)
        out = np.full((feats.visits.n, 2), np.nan)
        cams = feats.visits.camera
        for (cam, ax), est in self.estimators.items():
            m = cams == cam
            if m.any():
                out[m, 0 if ax == "u" else 1] = est.predict(x[m])
        return out


def fit_baseline(
    model: str,
    feats: Features,
    train: npt.NDArray[np.bool_],
    *,
    seed: int = 0,
) -> FittedBaseline:
    """Fit one baseline per (camera, axis) on the visits ``train`` marks (module docs).

    Parameters
    ----------
    model
        One of :data:`MODELS`.
    feats
        The visits' drift and regressors (:func:`features`).
    train
        Per visit, whether it is a training visit.
    seed
        Seed of the estimators' random draws (boosted trees, LASSO's coordinate order).
    """
    import warnings

    from sklearn.exceptions import ConvergenceWarning  # type: ignore[import-untyped]

    vs = feats.visits
    x = feats.matrix(model)
    ests: dict[tuple[str, str], Any] = {}
    pens: dict[str, float] = {}
    n_params = 0
    how: str | None = None
    for cam in dict.fromkeys(vs.camera[train].tolist()):
        rows = np.flatnonzero(train & (vs.camera == cam))
        folds, how_cv = cv_folds(vs.run[rows], vs.t_s[rows])
        for j, ax in enumerate(("u", "v")):
            est = _estimator(model, folds, seed)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", ConvergenceWarning)
                est.fit(x[rows], feats.drift[rows, j])
            ests[(cam, ax)] = est
            n_params += _n_params(model, est)
            if hasattr(est, "best_params_"):
                pens[f"{cam}/{ax}"] = float(est.best_params_["ridge__alpha"])
                how = how_cv
            elif hasattr(est, "steps") and hasattr(est.steps[-1][1], "alpha_"):
                pens[f"{cam}/{ax}"] = float(est.steps[-1][1].alpha_)
                how = how_cv
    temp_abs = feats.raw[train] + feats.first_c[train]
    rng_c = {
        t: [float(np.min(temp_abs[:, i])), float(np.max(temp_abs[:, i]))]
        for i, t in enumerate(feats.temperatures)
    }
    return FittedBaseline(model, ests, feats.names(model), n_params, how, pens, rng_c)


# --- scoring ----------------------------------------------------------------------------------


def _centred(
    resid: FloatArray, vs: Any
) -> FloatArray:  # n × 2 residual, centred per (run, camera, axis)
    out = resid.copy()
    for g in vs.groups:
        out[g] = resid[g] - np.mean(resid[g], axis=0)
    return out


def _rms(r: FloatArray) -> float:
    return float(np.sqrt(np.mean(r**2))) if r.size else float("nan")
