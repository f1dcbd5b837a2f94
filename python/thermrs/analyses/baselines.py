"""Data-driven baselines beside the physical model: regressions of the drift on the measured
temperatures, fitted on the diagnosis's training runs and scored on its held-out runs as the
diagnosis scores the nominal and the diagnosed model (``thermrs diagnose --baselines``).

What is regressed
    Per taught pose (camera) and chip axis, the measured spot relative to its run's first
    visit (the drift, µm) on features relative to the same visit: the ROI and room
    temperatures the run tables carry (de-noised as the diagnosis de-noises them,
    :func:`thermrs.diagnose.inputs.smooth_temperatures`); or those temperatures through
    first-order low-pass filters of a few time constants (:data:`LOWPASS_TAUS_MIN`, each run
    starting at equilibrium) and the time since the run began.
Models (:data:`MODELS`, scikit-learn estimators)
    ``ols`` (ordinary least squares on the temperatures), ``ridge`` (ridge on the standardised
    temperatures), ``lowpass_ols``, ``lowpass_ridge`` and ``lowpass_lasso`` (the same and LASSO
    on the low-pass features and time), ``gbt`` (gradient-boosted trees on the low-pass
    features and time). Every penalty is chosen by cross-validation *by run* (each training
    run left out in turn, :class:`sklearn.model_selection.LeaveOneGroupOut`); with a single
    training run, by contiguous blocks of it (:data:`SINGLE_RUN_BLOCKS`), never by visit.
Score
    A held-out run's residual is its drift minus the prediction, centred per (run, camera,
    axis): a held-out run's mounting is unknown, its offset the only thing fitted on it — as
    the diagnosis scores its models (:class:`thermrs.diagnose.engine.DesignMatrix`). The
    held-out rms pools both axes of every camera of every held-out run.
Intervals
    A moving-block bootstrap of whole cycles within each held-out run (the diagnosis's
    resampling unit, :mod:`thermrs.diagnose.resample`): every model's rms on the same draws, so
    that the difference between two models has its own interval; percentile intervals.
Parameters counted
    The law's fitted coefficients per camera and axis, summed: every coefficient of a least-
    squares fit, the non-zero ones of a penalised fit plus one for its chosen penalty, the
    leaves of every tree of a boosted model; the intercept (held-out scoring refits it per
    run, as it refits the physical model's offsets) is not counted. The nominal model has one
    (α), the diagnosed model α and its effects' numeric parameters (a discrete choice — which
    joint, which temperature — is not counted, as LASSO's choice of features is not).
The law
    The linear baseline with the least held-out rms, per camera and axis an intercept and a
    coefficient per feature in the features' own units, each with a 95 % interval from a
    moving-block bootstrap of whole training cycles (the penalty kept at the one
    cross-validation chose), and the range of temperatures it was fitted on
    (:class:`BaselineLaw`, ``thermrs compensate --model baseline``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt
import polars as pl

from thermrs.errors import InputError

__all__ = [
    "LOWPASS_TAUS_MIN",
    "MODELS",
    "BaselineComparison",
    "BaselineLaw",
    "Features",
    "FittedBaseline",
    "ModelScore",
    "baselines_folds",
    "compare_baselines",
    "cv_folds",
    "features",
    "fit_baseline",
    "lowpass",
    "said",
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
    from thermrs.diagnose.inputs import smooth_temperatures
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


@dataclass(frozen=True)
class ModelScore:
    """One model's score on the held-out runs.

    Attributes
    ----------
    name, kind, description
        The model (``nominal``, ``diagnosed`` or one of :data:`MODELS`), ``physical`` or
        ``regression``, and what it is.
    n_params
        Its fitted parameters (module docs).
    holdout_rms_um, holdout_rms_ci95
        Its held-out rms and 95 % interval (cycle bootstrap).
    train_rms_um
        Its rms on the training runs (offsets per run and camera removed).
    shrink
        1 − held-out rms / the nominal model's.
    minus_diagnosed_ci95
        The 95 % interval of its held-out rms minus the diagnosed model's, on the same
        bootstrap draws (``None`` without a diagnosis).
    per_run
        Per held-out run: ``run``, ``rms_um``, ``by_camera`` (``{camera: rms_um}``) and
        ``by_phase`` (``{phase: rms_um}``, the diagnosis's ``warm-up``, ``plateau`` and
        ``cool-down``).
    """

    name: str
    kind: str
    description: str
    n_params: int
    holdout_rms_um: float
    holdout_rms_ci95: tuple[float, float]
    train_rms_um: float
    shrink: float
    minus_diagnosed_ci95: tuple[float, float] | None
    per_run: list[dict[str, Any]]

    def to_json(self) -> dict[str, Any]:
        """The SPEC §7 ``baselines`` entry."""
        return {
            "name": self.name,
            "kind": self.kind,
            "description": self.description,
            "n_params": self.n_params,
            "holdout_rms_um": self.holdout_rms_um,
            "holdout_rms_ci95": list(self.holdout_rms_ci95),
            "train_rms_um": self.train_rms_um,
            "shrink": self.shrink,
            "minus_diagnosed_ci95": None
            if self.minus_diagnosed_ci95 is None
            else list(self.minus_diagnosed_ci95),
            "per_run": self.per_run,
        }


@dataclass(frozen=True)
class BaselineComparison:
    """The baselines beside the physical models on one split (:func:`compare_baselines`).

    Attributes
    ----------
    baselines
        The regressions' scores, in :data:`MODELS` order.
    nominal, diagnosed
        The nominal model's and the diagnosed model's (``None`` without a diagnosis) scores.
    noise_floor_um, noise_floor_ci95
        The held-out noise floor (the diagnosis's) and its interval where known.
    cv
        How the penalties were cross-validated.
    features
        The regressors of the temperature and of the low-pass models.
    fitted
        The fitted baselines (for predicting other runs).
    series
        Every visit's drift and each model's prediction of it, both centred per (run,
        camera, axis) as the score centres them: ``run``, ``role`` (``train``/``holdout``),
        ``camera``, ``axis``, ``t_h`` (hours since the run began), ``measured_um``, and a
        ``<model>_um`` column per model (``nominal``, ``diagnosed``, the baselines).
    """

    baselines: list[ModelScore]
    nominal: ModelScore
    diagnosed: ModelScore | None
    noise_floor_um: float
    noise_floor_ci95: tuple[float, float] | None
    cv: str | None
    features: dict[str, list[str]]
    fitted: list[FittedBaseline] = field(repr=False, default_factory=list)
    series: pl.DataFrame = field(repr=False, default_factory=pl.DataFrame)
    law: dict[str, Any] | None = None

    def to_json(self) -> dict[str, Any]:
        """``{"baselines": [...], "baselines_comparison": {...}}``: the keys
        ``thermrs diagnose --baselines --json`` adds (SPEC §7, docs/outputs.md)."""
        return {
            "baselines": [b.to_json() for b in self.baselines],
            "baselines_comparison": {
                "nominal": self.nominal.to_json(),
                "diagnosed": None if self.diagnosed is None else self.diagnosed.to_json(),
                "noise_floor_um": self.noise_floor_um,
                "noise_floor_ci95": None
                if self.noise_floor_ci95 is None
                else list(self.noise_floor_ci95),
                "cv": self.cv,
                "features": self.features,
                "penalties": {f.name: f.penalties for f in self.fitted if f.penalties},
                "train_range_c": self.fitted[0].train_range_c if self.fitted else {},
                "law": self.law,
                "target": "per camera and chip axis, the spot relative to its run's first "
                "visit (µm), on features relative to that visit",
                "score": "held-out residual centred per (run, camera, axis) — each held-out "
                "run's offset the only thing fitted on it, as the diagnosis scores — its rms "
                "over both axes of every camera of every held-out run",
                "interval": "moving-block bootstrap of whole cycles within each held-out run, "
                f"{DRAWS} draws shared by every model (percentile 95 % intervals)",
                "n_params": "the law's fitted coefficients summed over cameras and axes: "
                "every coefficient of least squares, the non-zero ones and one for the chosen "
                "penalty of ridge and LASSO, every "
                "leaf of every tree for boosted trees, α (and the effects' parameters) for the "
                "physical models; intercepts and offsets, refitted per held-out run, not "
                "counted",
            },
        }


def said(doc: dict[str, Any]) -> str:
    """Which regressions the diagnosed model is ahead of, which are ahead of it, and which the
    held-out runs cannot tell from it (the 95 % interval of the difference on the same draws),
    in one sentence, from :meth:`BaselineComparison.to_json`."""
    regs = doc["baselines"]
    if doc["baselines_comparison"]["diagnosed"] is None:
        return "No diagnosed model to compare with."
    ahead = [r["name"] for r in regs if r["minus_diagnosed_ci95"][0] > 0]
    behind = [r["name"] for r in regs if r["minus_diagnosed_ci95"][1] < 0]
    same = [r["name"] for r in regs if r["name"] not in ahead and r["name"] not in behind]
    parts = []
    if ahead:
        parts.append(f"the diagnosed physical model is ahead of {', '.join(ahead)}")
    if behind:
        parts.append(
            f"{', '.join(behind)} {'is' if len(behind) == 1 else 'are'} ahead of the diagnosed "
            "model (the drift holds something its effect library does not)"
        )
    if same:
        parts.append(f"{', '.join(same)} cannot be told from it on these runs")
    return "On these held-out runs " + "; ".join(parts) + " (95 % intervals of the difference)."


def _centred(
    resid: FloatArray, vs: Any
) -> FloatArray:  # n × 2 residual, centred per (run, camera, axis)
    out = resid.copy()
    for g in vs.groups:
        out[g] = resid[g] - np.mean(resid[g], axis=0)
    return out


def _rms(r: FloatArray) -> float:
    return float(np.sqrt(np.mean(r**2))) if r.size else float("nan")


def _per_run(
    r: FloatArray, vs: Any, hold: npt.NDArray[np.bool_], phase: npt.NDArray[np.str_]
) -> list[dict[str, Any]]:
    out = []
    for run in dict.fromkeys(vs.run[hold].tolist()):
        m = hold & (vs.run == run)
        out.append(
            {
                "run": run,
                "rms_um": _rms(r[m]),
                "by_camera": {
                    c: _rms(r[m & (vs.camera == c)]) for c in dict.fromkeys(vs.camera[m].tolist())
                },
                "by_phase": {
                    p: _rms(r[m & (phase == p)]) for p in dict.fromkeys(phase[m].tolist())
                },
            }
        )
    return out


def _bootstrap(
    resids: dict[str, FloatArray],
    vs: Any,
    hold: npt.NDArray[np.bool_],
    *,
    draws: int,
    rng: np.random.Generator,
) -> dict[str, FloatArray]:
    """Every model's held-out rms on the same moving-block resamples of whole cycles
    (module docs): ``{name: draws}``."""
    from thermrs.diagnose.resample import block_length, cycle_units
    from thermrs.stats import moving_block_indices

    units = cycle_units(vs)[hold]
    uniq, inv = np.unique(units, return_inverse=True)
    counts = np.bincount(inv, minlength=len(uniq)).astype(np.float64) * 2.0
    sums = {
        k: np.bincount(inv, weights=np.sum(r[hold] ** 2, axis=1), minlength=len(uniq))
        for k, r in resids.items()
    }
    first = np.zeros(len(uniq), dtype=np.intp)
    first[inv[::-1]] = np.flatnonzero(hold)[::-1]
    run_of = vs.run[first]
    length = max(
        block_length(s[run_of == r] / counts[run_of == r])
        for s in sums.values()
        for r in np.unique(run_of)
    )
    gen = moving_block_indices(run_of, block_length=length, rng=rng, order=uniq.astype(float))
    out = {k: np.empty(draws) for k in resids}
    for b in range(draws):
        idx = next(gen)
        c = counts[idx].sum()
        for k, s in sums.items():
            out[k][b] = np.sqrt(s[idx].sum() / c)
    return out


def _ci(x: FloatArray) -> tuple[float, float]:
    lo, hi = np.quantile(x, [0.025, 0.975])
    return float(lo), float(hi)


def compare_baselines(
    train: Sequence[pl.DataFrame],
    holdout: Sequence[pl.DataFrame],
    rig: Any,
    *,
    diagnosis: Any = None,
    models: Sequence[str] = MODELS,
    taus_min: Sequence[float] = LOWPASS_TAUS_MIN,
    draws: int = DRAWS,
    seed: int = 0,
    smooth: bool = True,
) -> BaselineComparison:
    """The baselines fitted on ``train`` and scored on ``holdout`` beside the nominal and the
    diagnosed model (module docs).

    Parameters
    ----------
    train, holdout
        Run tables, as :func:`thermrs.diagnose.diagnose` takes them.
    rig
        The rig (a :class:`~thermrs.rig.Rig` or its file).
    diagnosis
        The :class:`~thermrs.diagnose.result.Diagnosis` of the same runs: its diagnosed model
        and noise floor are scored beside (without it the floor is computed as the
        diagnosis's is, and there is no diagnosed model).
    models
        The baselines (:data:`MODELS`).
    taus_min
        Time constants of the low-pass features (minutes).
    draws
        Bootstrap draws of the intervals.
    seed
        Seed of the bootstrap and of the estimators.
    smooth
        De-noise the temperatures as the diagnosis does (:func:`features`); without, the
        nominal model too is fitted on the temperatures as read.

    Returns
    -------
    BaselineComparison

    Raises
    ------
    InputError
        No training or held-out run; a held-out camera no training run visits; a diagnosis of
        other runs; no temperature to regress on.

    Examples
    --------
    >>> c = thermrs.analyses.compare_baselines([run1], [run2, run3], rig)  # doctest: +SKIP
    >>> [(b.name, round(b.holdout_rms_um, 2)) for b in c.baselines]  # doctest: +SKIP
    """
    from thermrs.diagnose.engine import DesignMatrix
    from thermrs.diagnose.floor import noise_floor
    from thermrs.diagnose.location import phases
    from thermrs.rig import as_rig

    r = as_rig(rig)
    if not train:
        raise InputError("no training run: the baselines are fitted on --train runs")
    if not holdout:
        raise InputError("no held-out run: the baselines are scored on runs they never saw")
    for m in models:
        if m not in MODELS:
            raise InputError(f"baseline {m!r}: not one of {', '.join(MODELS)}")
    names_t = sorted({str(n) for t in train for n in t["run"].unique().to_list()})
    names_h = sorted({str(n) for t in holdout for n in t["run"].unique().to_list()})
    if diagnosis is not None:
        diagnosis.check_runs(names_t, names_h)
    feats = features([*train, *holdout], r, taus_min=taus_min, smooth=smooth)
    vs = feats.visits
    is_train = np.isin(vs.run, names_t)
    hold = ~is_train
    missing = sorted(set(vs.camera[hold].tolist()) - set(vs.camera[is_train].tolist()))
    if missing:
        raise InputError(
            f"held-out camera(s) {', '.join(missing)}: no training run visits them, so no "
            "baseline can be fitted for them"
        )
    n = vs.n

    # The physical models on the same visits: the nominal fit as the diagnosis makes it, the
    # diagnosed model's residual from the diagnosis itself.
    design = DesignMatrix(vs, set(names_t))
    base = design.fit(None, {}, label="nominal")
    resids: dict[str, FloatArray] = {
        "nominal": _centred(np.column_stack([base.residual[:n], base.residual[n:]]), vs)
    }
    n_par: dict[str, int] = {"nominal": 1}
    if diagnosis is not None:
        resids["diagnosed"] = _centred(_diagnosed_residual(diagnosis, vs), vs)
        n_par["diagnosed"] = 1 + sum(
            sum(isinstance(v, int | float) and not isinstance(v, bool) for v in p.values())
            for p in (s.get("params") or {} for s in diagnosis.selected)
        )
        floor_um = float(diagnosis.noise_floor_um)
        fci = (diagnosis.noise_floor or {}).get("holdout_ci95")
        floor_ci = None if not fci else (float(fci[0]), float(fci[1]))
    else:
        fl = noise_floor(vs, base.residual, set(names_h), r.mapped_temperatures)
        floor_um, floor_ci = float(fl.holdout_um), None

    fitted: list[FittedBaseline] = []
    for m in models:
        fb = fit_baseline(m, feats, is_train, seed=seed)
        fitted.append(fb)
        resids[m] = _centred(feats.drift - fb.predict(feats), vs)
        n_par[m] = fb.n_params

    boot = _bootstrap(resids, vs, hold, draws=draws, rng=np.random.default_rng(seed))
    # The diagnosis's phases (warm-up, plateau, cool-down) of every visit.
    phase = phases(vs, r.mapped_temperatures)
    nominal_rms = _rms(resids["nominal"][hold])

    def score(name: str, kind: str, description: str) -> ModelScore:
        rr = resids[name]
        h = _rms(rr[hold])
        return ModelScore(
            name=name,
            kind=kind,
            description=description,
            n_params=n_par[name],
            holdout_rms_um=h,
            holdout_rms_ci95=_ci(boot[name]),
            train_rms_um=_rms(rr[is_train]),
            shrink=1.0 - h / nominal_rms if nominal_rms > 0 else 0.0,
            minus_diagnosed_ci95=_ci(boot[name] - boot["diagnosed"])
            if "diagnosed" in boot
            else None,
            per_run=_per_run(rr, vs, hold, phase),
        )

    eff = [s.get("effect") for s in diagnosis.selected] if diagnosis is not None else []
    return BaselineComparison(
        baselines=[score(m, "regression", DESCRIPTIONS[m]) for m in models],
        nominal=score("nominal", "physical", "the rig's forward model, α fitted"),
        diagnosed=score(
            "diagnosed",
            "physical",
            "the forward model with " + (" + ".join(str(e) for e in eff) or "no effect added"),
        )
        if diagnosis is not None
        else None,
        noise_floor_um=floor_um,
        noise_floor_ci95=floor_ci,
        cv=next((f.cv for f in fitted if f.cv), None),
        features={
            "temperatures": feats.names("ols"),
            "lowpass": feats.names("lowpass_ols"),
        },
        fitted=fitted,
        series=_series(feats, resids, is_train),
        law=_best_law(fitted, resids, hold, feats, is_train, seed=seed),
    )


#: The baselines whose law is linear in their features (exported by ``compensate``).
LINEAR = ("ols", "ridge", "lowpass_ols", "lowpass_ridge", "lowpass_lasso")
#: Bootstrap draws of a law's coefficient intervals.
LAW_DRAWS = 199


def _fixed(model: str, est: Any) -> Any:
    """An unfitted copy of a fitted linear baseline with its penalty fixed at the one
    cross-validation chose (what a bootstrap refits)."""
    from sklearn.base import clone  # type: ignore[import-untyped]
    from sklearn.linear_model import Lasso, LinearRegression
    from sklearn.pipeline import make_pipeline
    from sklearn.preprocessing import StandardScaler

    if model in ("ols", "lowpass_ols"):
        return LinearRegression()
    if hasattr(est, "best_estimator_"):
        return clone(est.best_estimator_)
    alpha = float(est.steps[-1][1].alpha_)
    return make_pipeline(StandardScaler(), Lasso(alpha=alpha, max_iter=20_000))


def _effective(est: Any) -> tuple[float, FloatArray]:
    """A fitted linear baseline's intercept and coefficients in the features' own units (a
    standardising step folded in)."""
    final = est.best_estimator_ if hasattr(est, "best_estimator_") else est
    if hasattr(final, "steps"):
        scaler, reg = final.steps[0][1], final.steps[-1][1]
        w = np.ravel(reg.coef_) / scaler.scale_
        return float(reg.intercept_ - np.sum(w * scaler.mean_)), np.asarray(w, dtype=np.float64)
    return float(final.intercept_), np.asarray(np.ravel(final.coef_), dtype=np.float64)


def _best_law(
    fitted: list[FittedBaseline],
    resids: dict[str, FloatArray],
    hold: npt.NDArray[np.bool_],
    feats: Features,
    is_train: npt.NDArray[np.bool_],
    *,
    seed: int,
) -> dict[str, Any] | None:
    """The law of the linear baseline with the least held-out rms: per camera and axis its
    intercept and coefficients in the features' units, each with a 95 % interval from a
    moving-block bootstrap of whole training cycles within each training run, refitted with
    the penalty cross-validation chose (``thermrs compensate --model baseline``)."""
    import warnings

    from sklearn.exceptions import ConvergenceWarning

    from thermrs.diagnose.resample import block_length, cycle_units
    from thermrs.stats import moving_block_indices

    lin = [f for f in fitted if f.name in LINEAR]
    if not lin:
        return None
    best = min(lin, key=lambda f: _rms(resids[f.name][hold]))
    vs = feats.visits
    x = feats.matrix(best.name)
    units = cycle_units(vs)
    rng = np.random.default_rng([seed, 49])
    rows_out = []
    for (cam, ax), est in best.estimators.items():
        j = 0 if ax == "u" else 1
        rows = np.flatnonzero(is_train & (vs.camera == cam))
        b0, w = _effective(est)
        uniq, inv = np.unique(units[rows], return_inverse=True)
        first = np.zeros(len(uniq), dtype=np.intp)
        first[inv[::-1]] = rows[::-1]
        run_of = vs.run[first]
        r = resids[best.name][rows, j]
        per_cycle = np.bincount(inv, weights=r) / np.bincount(inv)
        length = max(block_length(per_cycle[run_of == q]) for q in np.unique(run_of))
        gen = moving_block_indices(run_of, block_length=length, rng=rng, order=uniq.astype(float))
        draws = np.empty((LAW_DRAWS, 1 + len(w)))
        members = [np.flatnonzero(inv == k) for k in range(len(uniq))]
        for b in range(LAW_DRAWS):
            pick = np.concatenate([members[k] for k in next(gen)])
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", ConvergenceWarning)
                e = _fixed(best.name, est).fit(x[rows[pick]], feats.drift[rows[pick], j])
            i0, wi = _effective(e)
            draws[b] = np.r_[i0, wi]
        lo, hi = np.quantile(draws, [0.025, 0.975], axis=0)
        rows_out.append(
            {
                "camera": cam,
                "axis": ax,
                "intercept_um": b0,
                "intercept_ci95": [float(lo[0]), float(hi[0])],
                "coefficients": {n: float(c) for n, c in zip(best.feature_names, w, strict=True)},
                "coefficients_ci95": {
                    n: [float(a), float(c)]
                    for n, a, c in zip(best.feature_names, lo[1:], hi[1:], strict=True)
                },
            }
        )
    taus = sorted({float(n.split("min_")[0][2:]) for n in best.feature_names if n.startswith("lp")})
    return {
        "model": best.name,
        "features": best.feature_names,
        "units": {n: ("µm/h" if n == "hours" else "µm/K") for n in best.feature_names},
        "reference": "each temperature relative to its value at the run's first visit of the "
        "pose; `d_<T>`: that difference; `lp<τ>min_<T>`: the temperature through a first-order "
        "low-pass filter of time constant τ minutes started at equilibrium at the first visit, "
        "less that value; `hours`: hours since the run began; the drift is relative to the "
        "first visit's spot",
        "lowpass_tau_min": taus,
        "smoothed_temperatures": feats.smoothed,
        "rows": rows_out,
        "train_range_c": best.train_range_c,
        "interval": f"moving-block bootstrap of whole training cycles within each training "
        f"run, {LAW_DRAWS} refits with the penalty cross-validation chose; percentile 95 %",
    }


def _series(
    feats: Features, resids: dict[str, FloatArray], is_train: npt.NDArray[np.bool_]
) -> pl.DataFrame:
    """The drift and each model's prediction per visit and axis (:class:`BaselineComparison`)."""
    vs = feats.visits
    measured = _centred(feats.drift, vs)
    cols: dict[str, Any] = {
        "run": np.concatenate([vs.run, vs.run]),
        "role": np.tile(np.where(is_train, "train", "holdout"), 2),
        "camera": np.concatenate([vs.camera, vs.camera]),
        "axis": np.repeat(["u", "v"], vs.n),
        "t_h": np.tile(vs.t_since_start / 3600.0, 2),
        "measured_um": np.concatenate([measured[:, 0], measured[:, 1]]),
    }
    for k, r in resids.items():
        pred = measured - r
        cols[f"{k}_um"] = np.concatenate([pred[:, 0], pred[:, 1]])
    return pl.DataFrame(cols)


def _diagnosed_residual(diagnosis: Any, vs: Any) -> FloatArray:
    """The diagnosed model's residual (the nominal one where no effect was selected) at every
    visit of ``vs`` (n × 2), from the diagnosis's residual table."""
    t = diagnosis.residuals
    if t.height == 0:
        raise InputError("the diagnosis carries no residuals: diagnose the runs again")
    col = "after_um" if t["after_um"].null_count() < t.height else "baseline_um"
    t = t.with_columns(pl.col(col).fill_null(pl.col("baseline_um")).alias("_r"))
    keys = pl.DataFrame(
        {
            "run": vs.run.tolist(),
            "camera": vs.camera.tolist(),
            "t_ns": vs.t_ns,
            "_i": np.arange(vs.n),
        }
    )
    out = np.full((vs.n, 2), np.nan)
    for j, ax in enumerate(("u", "v")):
        part = t.filter(pl.col("axis") == ax).select("run", "camera", "t_ns", "_r")
        joined = keys.join(part, on=["run", "camera", "t_ns"], how="left").sort("_i")
        out[:, j] = joined["_r"].to_numpy().astype(np.float64)
    if not np.all(np.isfinite(out)):
        raise InputError(
            "the diagnosis's residuals do not cover these runs' visits: it was made on other "
            "tables of them"
        )
    return out


def baselines_folds(
    folds: Sequence[Any],
    rig: Any,
    *,
    models: Sequence[str] = MODELS,
    draws: int = DRAWS,
    seed: int = 0,
) -> list[BaselineComparison]:
    """:func:`compare_baselines` on each diagnosed split (``thermrs diagnose --baselines``).

    Parameters
    ----------
    folds
        :class:`~thermrs.analyses.diagnose.DiagnosisFold` s
        (:func:`thermrs.analyses.diagnose.diagnose_splits`).
    rig
        The rig they were diagnosed with.
    models, draws, seed
        As :func:`compare_baselines`.

    Returns
    -------
    list of BaselineComparison
        One per fold, in order.
    """
    return [
        compare_baselines(
            f.split.train,
            f.split.holdout,
            rig,
            diagnosis=f.diagnosis,
            models=models,
            draws=draws,
            seed=seed,
        )
        for f in folds
    ]


@dataclass(frozen=True)
class BaselineLaw:
    """A regression baseline as a compensation law (``thermrs compensate --model baseline``):
    the ``law`` of a ``diagnose --baselines --json`` document.

    Attributes
    ----------
    doc
        The law (:meth:`BaselineComparison.to_json`, ``baselines_comparison.law``).
    score
        The model's ``baselines`` entry (its held-out rms and interval).
    """

    doc: dict[str, Any]
    score: dict[str, Any]

    @classmethod
    def from_diagnosis(cls, doc: dict[str, Any], *, source: str = "the diagnosis") -> BaselineLaw:
        """The law of a ``thermrs diagnose --baselines --json`` document.

        Raises
        ------
        InputError
            The document has no baselines, or none with a linear law.
        """
        comp = doc.get("baselines_comparison") if isinstance(doc, dict) else None
        if not comp:
            raise InputError(
                f"{source}: no baselines in it; make it with `thermrs diagnose --baselines --json`"
            )
        law = comp.get("law")
        if not law:
            raise InputError(f"{source}: none of its baselines is linear: no law to export")
        score: dict[str, Any] = next(
            (b for b in doc.get("baselines", []) if b.get("name") == law["model"]), {}
        )
        return cls(dict(law), dict(score))

    @property
    def model(self) -> str:
        """The baseline's name."""
        return str(self.doc["model"])

    def wide(self) -> pl.DataFrame:
        """One self-contained row per camera and chip axis: the intercept and a coefficient
        column per feature (``<feature>`` in µm/K or µm/h) with its 95 % interval
        (``<feature>_low``, ``<feature>_high``), the training range of every temperature
        (``<T>_min_c``, ``<T>_max_c``), the held-out rms and its interval."""
        out = []
        for r in self.doc["rows"]:
            row: dict[str, Any] = {
                "camera": r["camera"],
                "axis": r["axis"],
                "model": self.model,
                "intercept_um": r["intercept_um"],
                "intercept_low": r["intercept_ci95"][0],
                "intercept_high": r["intercept_ci95"][1],
            }
            for n in self.doc["features"]:
                row[n] = r["coefficients"][n]
                row[f"{n}_low"], row[f"{n}_high"] = r["coefficients_ci95"][n]
            for t, (lo, hi) in self.doc["train_range_c"].items():
                row[f"{t}_min_c"], row[f"{t}_max_c"] = lo, hi
            ci = self.score.get("holdout_rms_ci95") or [None, None]
            row["holdout_rms_um"] = self.score.get("holdout_rms_um")
            row["holdout_rms_low"], row["holdout_rms_high"] = ci
            out.append(row)
        return pl.DataFrame(out)

    def predict(self, feats: Features) -> FloatArray:
        """The drift the law predicts at every visit of ``feats`` (n × 2, µm; NaN for a camera
        it has no row for)."""
        names = self.doc["features"]
        have = feats.names(self.model)
        if sorted(names) != sorted(have):
            raise InputError(
                f"the law's features ({', '.join(names)}) are not these runs' ({', '.join(have)})"
            )
        x = feats.matrix(self.model)[:, [have.index(n) for n in names]]
        out = np.full((feats.visits.n, 2), np.nan)
        for r in self.doc["rows"]:
            m = feats.visits.camera == r["camera"]
            w = np.asarray([r["coefficients"][n] for n in names], dtype=np.float64)
            out[m, 0 if r["axis"] == "u" else 1] = r["intercept_um"] + x[m] @ w
        return out

    def check(self, tables: Sequence[pl.DataFrame], rig: Any) -> dict[str, Any]:
        """The law applied to runs: per run the rms it leaves (offset per camera and axis
        removed, as the diagnosis scores), and where a run's temperatures leave the range the
        law was fitted on (``outside``: one sentence per temperature and run)."""
        taus = self.doc.get("lowpass_tau_min") or list(LOWPASS_TAUS_MIN)
        feats = features(
            tables, rig, taus_min=taus, smooth=bool(self.doc.get("smoothed_temperatures", True))
        )
        vs = feats.visits
        r = _centred(feats.drift - self.predict(feats), vs)
        runs = []
        outside = []
        for run in dict.fromkeys(vs.run.tolist()):
            m = vs.run == run
            runs.append({"run": run, "compensated_rms_um": _rms(r[m])})
            temp = feats.raw[m] + feats.first_c[m]
            for i, t in enumerate(feats.temperatures):
                lo, hi = self.doc["train_range_c"].get(t, [-np.inf, np.inf])
                a, b = float(np.min(temp[:, i])), float(np.max(temp[:, i]))
                if a < lo - 1e-9 or b > hi + 1e-9:
                    outside.append(
                        f"run {run}: {t} spans {a:.2f}–{b:.2f} °C, outside the "
                        f"{lo:.2f}–{hi:.2f} °C the law was fitted on"
                    )
        return {"runs": runs, "all_rms_um": _rms(r), "outside": outside}
