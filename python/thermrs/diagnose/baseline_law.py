"""The best linear baseline as a compensation law (``thermrs compensate --model baseline``):
its coefficients with intervals from a bootstrap of whole training cycles, and the range of
temperatures it was fitted on."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt
import polars as pl

from thermrs.diagnose.baseline_models import (
    LOWPASS_TAUS_MIN,
    Features,
    FittedBaseline,
    _centred,
    _rms,
    features,
)
from thermrs.errors import InputError

__all__ = ["LINEAR", "BaselineLaw"]

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]

#: The baselines whose law is linear in their features (exported by ``compensate``).
LINEAR = ("ols", "ridge", "lowpass_ols", "lowpass_ridge", "lowpass_lasso")
#: Bootstrap draws of a law's coefficient intervals.
LAW_DRAWS = 199


def _fixed(model: str, est: Any) -> Any:
    """An unfitted copy of a fitted linear baseline with its penalty fixed at the one
    cross-validation chose (what a bootstrap refits)."""
    from sklearn.base import clone  # type: ignore[import-untyped]
    from sklearn.linear_model import Lasso, LinearRegression  # type: ignore[import-untyped]
    from sklearn.pipeline import make_pipeline  # type: ignore[import-untyped]
    from sklearn.preprocessing import StandardScaler  # type: ignore[import-untyped]

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

    from sklearn.exceptions import ConvergenceWarning  # type: ignore[import-untyped]

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
