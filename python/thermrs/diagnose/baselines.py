"""Data-driven baselines beside the physical model: regressions of the drift on the measured
temperatures, fitted on the diagnosis's training runs and scored on its held-out runs as the
diagnosis scores the nominal and the diagnosed model (``thermrs diagnose --baselines``).

What is regressed
    Per taught pose (camera) and chip axis, the measured spot relative to its run's first
    visit (the drift, µm) on features relative to the same visit: the ROI and room
    temperatures the run tables carry (de-noised as the diagnosis de-noises them,
    :func:`thermrs.diagnose.input_checks.smooth_temperatures`); or those temperatures through
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
    the diagnosis scores its models (:class:`thermrs.diagnose.family_fit.DesignMatrix`). The
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

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt
import polars as pl

from thermrs.diagnose.baseline_law import _best_law
from thermrs.diagnose.baseline_models import (
    DESCRIPTIONS,
    DRAWS,
    LOWPASS_TAUS_MIN,
    MODELS,
    Features,
    FittedBaseline,
    _centred,
    _rms,
    features,
    fit_baseline,
)
from thermrs.errors import InputError

__all__ = [
    "BaselineComparison",
    "ModelScore",
    "baselines_folds",
    "compare_baselines",
    "row_cells",
    "said",
]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]


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


def row_cells(r: dict[str, Any], *, with_diagnosed: bool, num: Callable[..., str]) -> list[str]:
    """One model's cells in a comparison table (the CLI's and the report's): name, what,
    parameters, held-out rms with its interval, per held-out run, and the interval of its
    difference from the diagnosed model. ``num(x, sign=False)`` formats a number."""
    lo, hi = r["holdout_rms_ci95"]
    cells = [
        r["name"],
        r["description"],
        str(r["n_params"]),
        f"{num(r['holdout_rms_um'])} [{num(lo)}, {num(hi)}]",
        *(num(p["rms_um"]) for p in r["per_run"]),
    ]
    if with_diagnosed:
        d = r["minus_diagnosed_ci95"]
        cells.append(
            "—" if r["name"] == "diagnosed" else f"[{num(d[0], sign=True)}, {num(d[1], sign=True)}]"
        )
    return cells


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
    from thermrs.diagnose.location import phases
    from thermrs.rig import as_rig

    r = as_rig(rig)
    names_t, names_h = _run_names(train, holdout, models, diagnosis)
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

    resids, n_par, floor_um, floor_ci = _physical(vs, names_t, names_h, r, diagnosis)

    fitted: list[FittedBaseline] = []
    for m in models:
        fb = fit_baseline(m, feats, is_train, seed=seed)
        fitted.append(fb)
        resids[m] = _centred(feats.drift - fb.predict(feats), vs)
        n_par[m] = fb.n_params

    boot = _bootstrap(resids, vs, hold, draws=draws, rng=np.random.default_rng(seed))
    # The diagnosis's phases (warm-up, plateau, cool-down) of every visit.
    phase = phases(vs, r.mapped_temperatures)
    scores = _scores(models, resids, n_par, boot, vs, is_train, phase, diagnosis)

    return BaselineComparison(
        baselines=scores[0],
        nominal=scores[1],
        diagnosed=scores[2],
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


def _run_names(
    train: Sequence[pl.DataFrame],
    holdout: Sequence[pl.DataFrame],
    models: Sequence[str],
    diagnosis: Any,
) -> tuple[list[str], list[str]]:
    """The training and held-out runs' names, once the runs, the models and the diagnosis
    are checked (:func:`compare_baselines`' ``InputError``)."""
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
    return names_t, names_h


def _physical(
    vs: Any, names_t: list[str], names_h: list[str], r: Any, diagnosis: Any
) -> tuple[dict[str, FloatArray], dict[str, int], float, tuple[float, float] | None]:
    """The physical models on the baselines' visits: the nominal fit as the diagnosis makes
    it and the diagnosed model's residual from the diagnosis itself (centred), their
    parameter counts, and the noise floor (the diagnosis', else computed as it computes it)
    with its 95 % interval where known."""
    from thermrs.diagnose.family_fit import DesignMatrix
    from thermrs.diagnose.floor import noise_floor

    n = vs.n
    base = DesignMatrix(vs, set(names_t)).fit(None, {}, label="nominal")
    resids: dict[str, FloatArray] = {
        "nominal": _centred(np.column_stack([base.residual[:n], base.residual[n:]]), vs)
    }
    n_par: dict[str, int] = {"nominal": 1}
    if diagnosis is None:
        fl = noise_floor(vs, base.residual, set(names_h), r.mapped_temperatures)
        return resids, n_par, float(fl.holdout_um), None
    resids["diagnosed"] = _centred(_diagnosed_residual(diagnosis, vs), vs)
    n_par["diagnosed"] = 1 + sum(
        sum(isinstance(v, int | float) and not isinstance(v, bool) for v in p.values())
        for p in (s.get("params") or {} for s in diagnosis.selected)
    )
    fci = (diagnosis.noise_floor or {}).get("holdout_ci95")
    return (
        resids,
        n_par,
        float(diagnosis.noise_floor_um),
        (None if not fci else (float(fci[0]), float(fci[1]))),
    )


def _scores(
    models: Sequence[str],
    resids: dict[str, FloatArray],
    n_par: dict[str, int],
    boot: dict[str, FloatArray],
    vs: Any,
    is_train: npt.NDArray[np.bool_],
    phase: Any,
    diagnosis: Any,
) -> tuple[list[ModelScore], ModelScore, ModelScore | None]:
    """Every model scored on the held-out visits: the baselines, the nominal model and (with
    a diagnosis) the diagnosed one."""
    hold = ~is_train
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
    return (
        [score(m, "regression", DESCRIPTIONS[m]) for m in models],
        score("nominal", "physical", "the rig's forward model, α fitted"),
        score(
            "diagnosed",
            "physical",
            "the forward model with " + (" + ".join(str(e) for e in eff) or "no effect added"),
        )
        if diagnosis is not None
        else None,
    )


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

    Raises
    ------
    InputError
        As :func:`compare_baselines`: runs too short or without temperatures to regress on.

    Examples
    --------
    >>> folds = thermrs.analyses.diagnose_splits(splits, rig)  # doctest: +SKIP
    >>> [c.to_json()["baselines"][0]["name"] for c in baselines_folds(folds, rig)]  # doctest: +SKIP
    ['ols', ...]
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
