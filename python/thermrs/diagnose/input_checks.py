"""Checking what the diagnoser is given: run tables, distinct names, known effect names."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import polars as pl

from thermrs.effects import EFFECT_NAMES, Effect, effect_classes
from thermrs.errors import InputError
from thermrs.memo import ContentCache, content_key
from thermrs.rig import Rig
from thermrs.stats import loess2

__all__ = ["check_inputs", "smooth_temperatures"]


def _check_runs(tables: Sequence[pl.DataFrame], what: str) -> list[pl.DataFrame]:
    if isinstance(tables, pl.DataFrame):
        tables = [tables]
    out = []
    for t in tables:
        if not isinstance(t, pl.DataFrame):
            raise TypeError(
                f"{what} runs must be run tables (polars DataFrames), got {type(t).__name__}"
            )
        for c in ("run", "camera", "t_ns", "u_um", "v_um"):
            if c not in t.columns:
                raise InputError(
                    f"a {what} run table has no `{c}` column (see thermrs.fit.run_table)"
                )
        if t.filter(pl.col("u_um").is_finite()).height == 0:
            name = t["run"][0] if t.height else "?"
            raise InputError(f"{what} run {name!r} has no visits with a spot")
        out.append(t)
    return out


#: Visits a diagnosis needs per camera and run (each run's unknown mounting takes one).
MIN_VISITS = 3


def check_visits(train: Sequence[pl.DataFrame], holdout: Sequence[pl.DataFrame]) -> None:
    """Every camera of every run has the visits a diagnosis needs (:data:`MIN_VISITS`).

    Raises
    ------
    InputError
        One line naming the run and camera.
    """
    for role, tables in (("--train", train), ("--holdout", holdout)):
        for t in tables:
            if t.height == 0 or "camera" not in t.columns:
                continue
            for cam, n in t.group_by("camera").len().sort("camera").iter_rows():
                if n < MIN_VISITS:
                    raise InputError(
                        f"{role} run {t['run'][0]}: camera {cam} has {n} visit(s); a diagnosis "
                        f"needs at least {MIN_VISITS} per camera and run (each run's unknown "
                        "mounting takes one)"
                    )


def check_inputs(
    train: Sequence[pl.DataFrame],
    holdout: Sequence[pl.DataFrame],
    rig: Rig,
    exclude: Sequence[str],
    library: Sequence[type[Effect]] | None,
) -> tuple[list[pl.DataFrame], list[pl.DataFrame], list[str], dict[str, type[Effect]]]:
    """(training tables, held-out tables, training run names, the effect classes the
    diagnoser may use: the library without the excluded ones)."""
    if isinstance(rig, str) or not isinstance(rig, Rig):
        raise TypeError(
            f"rig must be a thermrs.Rig (thermrs.load_rig(path)), got {type(rig).__name__}"
        )
    tr = _check_runs(train, "training")
    ho = _check_runs(holdout, "held-out")
    check_visits(tr, ho)
    if not tr:
        raise InputError(
            "no training run: the nominal model and each effect are fitted on --train runs"
        )
    if not ho:
        raise InputError("no held-out run: effects are scored on runs they were not fitted on")
    names_t = [str(n) for t in tr for n in t["run"].unique().to_list()]
    names_h = [str(n) for t in ho for n in t["run"].unique().to_list()]
    both = sorted(set(names_t) & set(names_h))
    if both or len(set(names_t)) != len(names_t) or len(set(names_h)) != len(names_h):
        raise InputError(
            "run names must be distinct across --train and --holdout "
            f"(repeated: {both or 'within one side'})"
        )
    classes = dict(effect_classes()) if library is None else {c.name: c for c in library}
    unknown = sorted(set(exclude) - set(classes) - set(EFFECT_NAMES))
    if unknown:
        raise InputError(f"--exclude {unknown}: not effects (known: {', '.join(EFFECT_NAMES)})")
    # An excluded effect is gone from the library: it can neither be named nor veto another
    # (the withheld-effect check is then what it is for an effect nobody has thought of).
    for e in exclude:
        classes.pop(e, None)
    return tr, ho, names_t, classes


def smooth_temperatures(tables: list[pl.DataFrame], half_width_s: float) -> list[pl.DataFrame]:
    """The run tables with every temperature column (``*_c``) de-noised per (run, camera)
    series by a local quadratic regression (tricube weights, ±``half_width_s``).

    A temperature read by an IR camera carries reading noise from visit to visit; fed through
    the model it is visit-to-visit noise on the predicted spot, which any smoothing effect
    (a short thermal lag, above all) would "explain". The links' temperatures change on the
    thermal time scales, so a symmetric smoother over a window well below them (± two of the
    floor's allowed correlation times, a fifth of the shortest thermal time constant) takes
    the reading noise out without shifting the heating curve (a local quadratic follows its
    bend to third order).
    """
    if half_width_s <= 0:
        return tables
    out = []
    for t in tables:
        cols = [c for c in t.columns if c.endswith("_c") and t[c].dtype.is_numeric()]
        if not cols:
            out.append(t)
            continue
        t = t.with_row_index("__row")
        parts = []
        for _, g in t.sort("t_ns").group_by(["run", "camera"], maintain_order=True):
            ts = (g["t_ns"].to_numpy() - g["t_ns"].to_numpy()[0]).astype(np.float64) / 1e9
            new = {c: _smoothed(ts, g[c].to_numpy(), half_width_s) for c in cols}
            parts.append(g.with_columns(**{c: pl.Series(c, v) for c, v in new.items()}))
        out.append(pl.concat(parts).sort("__row").drop("__row"))
    return out


#: Smoothed series by the content of their samples (a proof diagnoses the user's runs again).
_SMOOTHED: ContentCache[np.ndarray] = ContentCache(256)


def _smoothed(ts: np.ndarray, y: np.ndarray, half_width_s: float) -> np.ndarray:
    """:func:`loess2` of one series, kept by its samples (the result is shared: read only)."""
    y = np.asarray(y, dtype=np.float64)

    def compute() -> np.ndarray:
        out = loess2(ts, y, half_width_s)
        out.setflags(write=False)
        return out

    return _SMOOTHED.get(content_key(ts, y, float(half_width_s)), compute)
