"""``thermrs predict``: held-out runs predicted from their temperatures, with the α fitted on
training runs or given, one :class:`Prediction` per split."""

from __future__ import annotations

import json
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import polars as pl

from thermrs.analyses.inputs import DatasetLike, Split, selected, splits
from thermrs.fit import FitResult

__all__ = [
    "DiagnosedPrediction",
    "Prediction",
    "predict",
    "predict_diagnosed",
    "predict_splits",
    "predict_synthesis",
    "read_fit_alpha",
]


@dataclass(frozen=True)
class Prediction:
    """One split's prediction (``thermrs predict``).

    Attributes
    ----------
    split
        The training and held-out runs.
    alphas
        The α values predicted with, by label (:func:`thermrs.analyses.fit.training_alphas`, or
        the α given).
    table
        :func:`thermrs.predict.prediction_table` of the held-out runs.
    series
        Every held-out visit's predicted and measured drift, per α (``alpha`` column: label).
    fit
        The fit on the training runs the α values come from (``None`` where α was given).
    """

    split: Split
    alphas: dict[str, float]
    table: pl.DataFrame
    series: pl.DataFrame
    fit: FitResult | None = None

    def centred_residuals(self, label: str = "series") -> Any:
        """Measured − predicted drift (µm) with the α labelled ``label`` over every held-out
        visit and both chip axes, each (run, camera, axis) series' mean removed (a numpy
        array)."""
        import numpy as np

        s = self.series.filter(pl.col("alpha") == label)
        parts = []
        for _, g in s.group_by(["run", "camera"], maintain_order=True):
            for a in "uv":
                r = g[f"residual_{a}_um"].to_numpy()
                r = r[np.isfinite(r)]
                if len(r):
                    parts.append(r - r.mean())
        return np.concatenate(parts) if parts else np.zeros(0)

    def rms_um(self, label: str = "series") -> float:
        """The held-out rms (µm) with the α labelled ``label``: the root mean square of
        :meth:`centred_residuals` — the definition of the per-run ``rms_centred_um``, pooled."""
        import numpy as np

        r = self.centred_residuals(label)
        return float(np.sqrt(np.mean(r**2))) if r.size else float("nan")

    def to_json(self) -> dict[str, Any]:
        """The ``thermrs predict --json`` document of this split (with its fold and runs)."""
        return {
            "fold": self.split.name,
            "train": self.split.train_names,
            "holdout": self.split.holdout_names,
            "alpha_per_k": self.alphas,
            "table": self.table.drop("alpha_per_k").to_dicts(),
        }


def predict_splits(
    sets: Sequence[Split],
    rig: Any,
    *,
    alphas: Mapping[str, float] | None = None,
    axis: str = "auto",
    end_visits: int = 1,
) -> list[Prediction]:
    """Per split, its held-out runs predicted with ``alphas`` or, without, with the α fitted
    on its training runs (:func:`thermrs.predict.predict_held_out`).

    Parameters
    ----------
    sets
        The splits (:func:`~thermrs.analyses.inputs.splits`,
        :func:`~thermrs.analyses.inputs.file_splits`).
    rig
        The rig (a :class:`~thermrs.rig.Rig` or its file).
    alphas, axis, end_visits
        As :func:`thermrs.predict.predict_held_out`.

    Returns
    -------
    list of Prediction
        One per split, in their order.

    Raises
    ------
    InputError
        What :func:`thermrs.predict.predict_held_out` raises.

    Examples
    --------
    >>> sets = thermrs.analyses.file_splits(["rec.mcap#a"], ["rec.mcap#b"], rig)  # doctest: +SKIP
    >>> (p,) = thermrs.analyses.predict_splits(sets, rig)  # doctest: +SKIP
    >>> p.table  # doctest: +SKIP
    """
    from thermrs.predict import predict_held_out

    res = []
    for s in sets:
        p = predict_held_out(
            s.train, s.holdout, rig, alphas=alphas, axis=axis, end_visits=end_visits
        )
        res.append(Prediction(s, p.alphas, p.table, p.series, p.fit))
    return res


def predict(
    dataset: DatasetLike,
    rig: Any,
    *,
    where: str | None = None,
    rule: str | None = None,
    train: Sequence[str] = (),
    runs: Sequence[str] = (),
    alpha_per_k: float | None = None,
    axis: str = "auto",
    end_visits: int = 1,
) -> list[Prediction]:
    """Held-out runs of a campaign predicted from their temperatures, as ``thermrs predict
    --campaign`` does.

    Parameters
    ----------
    dataset, rig, where
        As :func:`thermrs.analyses.fit.fit`.
    rule
        ``leave-one-run-out`` or ``by-day``: a prediction per fold, α fitted on its training
        runs.
    train
        Else the runs α is fitted on (names); ``runs`` default to the other runs chosen.
    runs
        The runs to predict (names; default: every run chosen that is not trained on).
    alpha_per_k
        Else predict with this α (1/K): no rule, no training runs.
    axis, end_visits
        As :func:`thermrs.predict.prediction_table`.

    Returns
    -------
    list of Prediction
        One per fold (one without a rule): the α values, the Table 7-style table, the series.

    Raises
    ------
    InputError
        What :func:`~thermrs.analyses.inputs.splits` raises; α given with a rule or training
        runs; no run left to predict.

    Examples
    --------
    >>> folds = thermrs.analyses.predict("campaign/", rig, rule="by-day")  # doctest: +SKIP
    >>> [(p.split.name, p.rms_um()) for p in folds]  # doctest: +SKIP
    """
    from thermrs.errors import InputError

    if alpha_per_k is not None:
        if rule or train:
            raise InputError("α given: no rule and no training runs")
        s = selected(dataset, rig, where=where, names=runs)
        sets = [Split("", [], s.train, s.data_loss)]
        return predict_splits(
            sets, rig, alphas={"given": alpha_per_k}, axis=axis, end_visits=end_visits
        )
    sets = splits(dataset, rig, where=where, rule=rule, train=train, holdout=runs)
    if any(not s.holdout for s in sets):
        raise InputError("no run left to predict: every selected run is a training run")
    return predict_splits(sets, rig, axis=axis, end_visits=end_visits)


def read_fit_alpha(path: str | os.PathLike[str], *, what: str = "--fit") -> float:
    """α (1/K) from a ``thermrs fit --json`` document.

    Parameters
    ----------
    path
        The document.
    what
        The option it was given with, for messages.

    Returns
    -------
    float
        α in 1/K.

    Raises
    ------
    InputError
        No such file, not such a document, or an α out of range (the message starts with
        ``what`` and the path).

    Examples
    --------
    >>> thermrs.analyses.read_fit_alpha("fit.json")  # doctest: +SKIP
    """
    from thermrs.errors import InputError
    from thermrs.predict import check_alpha

    p = Path(path)
    try:
        doc = json.loads(p.read_text())
        return check_alpha(doc["alpha_per_k"]["value"], what=f"{what} {p}:")
    except FileNotFoundError:
        raise InputError(f"{what} {p}: no such file") from None
    except (ValueError, KeyError, TypeError) as e:
        why = f"{type(e).__name__}: {e}".splitlines()[0]
        raise InputError(f"{what} {p}: not a `thermrs fit --json` file ({why})") from None


@dataclass(frozen=True)
class DiagnosedPrediction:
    """Held-out runs predicted by the nominal model and by a diagnosed one (``thermrs predict
    --diagnosis``).

    Attributes
    ----------
    model
        The diagnosed model (:class:`thermrs.compensate.DiagnosedModel`).
    series
        Every held-out visit, both predictions (:func:`thermrs.compensate.predict_series`).
    shrink
        The error before and after per run and camera (:func:`thermrs.compensate.shrink_table`).
    """

    model: Any
    series: pl.DataFrame
    shrink: pl.DataFrame

    def to_json(self) -> dict[str, Any]:
        """The ``thermrs predict --diagnosis --json`` document."""
        m = self.model
        return {
            "alpha_per_k": {"nominal": m.nominal_alpha_per_k, "diagnosed": m.alpha_per_k},
            "effects": [e.to_dict() for e in m.effects],
            "promised_shrink": m.promised_shrink,
            "table": self.shrink.to_dicts(),
        }


def predict_diagnosed(
    held: Sequence[pl.DataFrame], rig: Any, diagnosis: str | os.PathLike[str] | Mapping[str, Any]
) -> DiagnosedPrediction:
    """Held-out runs predicted by the nominal model and by the model a diagnosis identified
    (α and its effect), with the error before and after per run and camera.

    Parameters
    ----------
    held
        The held-out run tables.
    rig
        The rig (a :class:`~thermrs.rig.Rig` or its file).
    diagnosis
        A ``thermrs diagnose --json`` file or its document.

    Returns
    -------
    DiagnosedPrediction
        The model, the series and the before/after table.

    Raises
    ------
    InputError
        Not a diagnosis of this rig (:func:`thermrs.compensate.load_diagnosis`).

    Examples
    --------
    >>> p = predict_diagnosed(runs.tables, rig, "diagnosis.json")  # doctest: +SKIP
    >>> p.shrink.select("run", "camera", "shrink")  # doctest: +SKIP
    """
    from thermrs.compensate import diagnosed_model, load_diagnosis, predict_series, shrink_table
    from thermrs.rig import as_rig

    r = as_rig(rig)
    if isinstance(diagnosis, Mapping):
        model = diagnosed_model(dict(diagnosis), r)
    else:
        model = load_diagnosis(Path(diagnosis), r)
    series = predict_series(list(held), r, model)
    return DiagnosedPrediction(model, series, shrink_table(series))


def predict_synthesis(preds: Sequence[Prediction], *, label: str = "series") -> dict[str, Any]:
    """What the folds of a rule say together about prediction (``thermrs predict --rule``).

    Parameters
    ----------
    preds
        The folds' predictions (:func:`predict_splits`).
    label
        The α each fold predicted with (default the time-series fit on its training runs).

    Returns
    -------
    dict
        ``folds``, ``holdout_rms_um`` (every fold's held-out visits pooled: the root mean
        square of each fold's mean-removed residual series together), ``fold_rms_um`` [min,
        max], ``alpha_per_k`` [min, max] over the folds, ``worst_fold`` and ``sentence``.

    Raises
    ------
    KeyError
        A fold without the α ``label``.

    Examples
    --------
    >>> from thermrs import analyses, load_rig
    >>> rig = load_rig("rig.toml")  # doctest: +SKIP
    >>> folds = analyses.predict("campaign/", rig, rule="leave-one-run-out")  # doctest: +SKIP
    >>> analyses.predict_synthesis(folds)["sentence"]  # doctest: +SKIP
    """
    import numpy as np

    parts = [p.centred_residuals(label) for p in preds]  # each fold's residuals, read once
    rms = [float(np.sqrt(np.mean(r**2))) if r.size else float("nan") for r in parts]
    pooled = np.concatenate([np.zeros(0), *parts])
    alphas = [float(p.alphas[label]) for p in preds if label in p.alphas]
    if len(pooled) == 0:
        return {
            "folds": len(preds),
            "holdout_rms_um": None,
            "fold_rms_um": None,
            "alpha_per_k": None,
            "worst_fold": None,
            "sentence": "no held-out visit to score",
        }
    total = float(np.sqrt(np.mean(pooled**2)))
    worst = int(np.nanargmax(rms))
    sentence = (
        f"held-out rms {total:.3f} µm over {len(preds)} fold(s) (every held-out visit pooled; "
        f"folds {np.nanmin(rms):.3f}–{np.nanmax(rms):.3f} µm, the worst {preds[worst].split.name})"
    )
    if alphas:
        sentence += f"; α {min(alphas) * 1e6:.3f}–{max(alphas) * 1e6:.3f} ×10⁻⁶/K"
    return {
        "folds": len(preds),
        "holdout_rms_um": total,
        "fold_rms_um": [float(np.nanmin(rms)), float(np.nanmax(rms))],
        "alpha_per_k": [min(alphas), max(alphas)] if alphas else None,
        "worst_fold": preds[worst].split.name,
        "sentence": sentence,
    }
