"""The runs of a campaign chosen by query, training and held-out sets by rule, and the run
tables that fit, predict, drift and diagnose take.

A query is a comma-separated list of terms ``KEY OP VALUE`` (all must hold), ``OP`` one of
``= != < <= > >=``; keys: ``robot``, ``rig``, ``recording``, ``run`` (text), ``date``
(``YYYY-MM-DD``, the UTC day the run started), ``speed`` (°/s, the run's 95th-percentile
joint speed, see :func:`thermrs.campaigns.task.run_stats`), ``duration`` (s). Example:
``robot=KR 15/2, date>=2026-11-02, speed>20``.

Rules (:func:`folds`): ``leave-one-run-out`` (each run held out once, trained on all the
others), ``by-day`` (train on one day's runs, hold out the next day's, for each pair of
consecutive days).
"""

from __future__ import annotations

import itertools
import re
from dataclasses import dataclass
from datetime import date
from typing import Any

import polars as pl

from thermrs.campaigns.dataset import Dataset
from thermrs.errors import InputError

__all__ = ["RULES", "Fold", "campaign_runs", "folds", "parse_query", "run_tables"]

_KEYS: dict[str, tuple[str, Any]] = {
    "robot": ("robot", str),
    "rig": ("rig", str),
    "recording": ("recording", str),
    "run": ("run", str),
    "date": ("date", date.fromisoformat),
    "speed": ("speed_deg_s", float),
    "duration": ("duration_s", float),
}
_TERM = re.compile(r"^\s*([a-z]+)\s*(<=|>=|!=|=|<|>)\s*(.*?)\s*$")
RULES = ("leave-one-run-out", "by-day")


def parse_query(query: str | None) -> pl.Expr:
    """A polars filter from a query (see the module docs); ``None`` or ``""``: every run.

    Raises
    ------
    InputError
        A term that does not parse, an unknown key, a value of the wrong kind; the message
        names the term.
    """
    expr = pl.lit(True)
    for term in (query or "").split(","):
        if not term.strip():
            continue
        m = _TERM.match(term)
        if not m:
            raise InputError(f"run query term {term.strip()!r}: expected KEY OP VALUE")
        key, op, raw = m.groups()
        if key not in _KEYS:
            raise InputError(
                f"run query term {term.strip()!r}: unknown key {key!r} (keys: {', '.join(_KEYS)})"
            )
        col, kind = _KEYS[key]
        try:
            value = kind(raw)
        except ValueError:
            raise InputError(
                f"run query term {term.strip()!r}: {raw!r} is not a {kind.__name__}"
            ) from None
        c = pl.col(col)
        expr = (
            expr
            & {
                "=": c == value,
                "!=": c != value,
                "<": c < value,
                "<=": c <= value,
                ">": c > value,
                ">=": c >= value,
            }[op]
        )
    return expr


def campaign_runs(dataset: Dataset, query: str | None = None) -> pl.DataFrame:
    """One row per run of the campaign that the query selects: the runs table joined with
    the catalog (``recording``, ``run``, ``robot``, ``rig``, ``date``, ``speed_deg_s``,
    ``duration_s``, ``start_ns``, ``end_ns``, ``frames``, ``visits``, ``losses``), in time
    order.

    Raises
    ------
    InputError
        A bad query; or no run matches it (the message says how many runs there are).
    """
    cat = dataset.catalog().select(
        "recording", "robot", "rig", "rig_hash", "losses", "content_hash"
    )
    runs = dataset.scan("runs").collect()
    if runs.height == 0:
        raise InputError(f"dataset {dataset.root}: holds no run")
    table = runs.join(cat, on="recording", how="inner").sort("start_ns", "recording")
    picked = table.filter(parse_query(query))
    if picked.height == 0:
        raise InputError(
            f"dataset {dataset.root}: no run matches {query!r} (of {table.height} runs)"
        )
    return picked


def run_tables(
    dataset: Dataset, runs: pl.DataFrame, rig: Any, *, temperature: str = "peak"
) -> list[pl.DataFrame]:
    """The run tables (:func:`thermrs.fit.run_table_from`) of the given runs, named
    ``<recording>#<run>``, drift anchored per run (SPEC §1), in the order of ``runs``.

    Raises
    ------
    InputError
        A run was extracted with a rig that differs from ``rig`` in anything that changes
        numbers (the catalog's ``rig_hash``; comments and tolerances do not count).
    """
    from thermrs.fit import run_table_from
    from thermrs.visits import anchor_drift

    check_rig(dataset, runs, rig)

    keys = runs.select("recording", "run")
    visits = dataset.scan("visits").join(keys.lazy(), on=["recording", "run"]).collect()
    recs = keys["recording"].unique().to_list()
    temps = dataset.scan("temperatures").filter(pl.col("recording").is_in(recs)).collect()
    out = []
    for r in runs.iter_rows(named=True):
        v = visits.filter((pl.col("recording") == r["recording"]) & (pl.col("run") == r["run"]))
        t = temps.filter(
            (pl.col("recording") == r["recording"])
            & pl.col("t_ns").is_between(r["start_ns"], r["end_ns"])
        )
        out.append(
            run_table_from(
                anchor_drift(v.drop("recording")),
                t.drop("recording", "run"),
                rig,
                run=f"{r['recording']}#{r['run']}",
                temperature=temperature,
            )
        )
    return out


def check_rig(dataset: Dataset, runs: pl.DataFrame, rig: Any) -> None:
    """Raise :class:`InputError` unless every run of ``runs`` (with the catalog's
    ``rig_hash``) was extracted with ``rig`` (the same validated rig: a comment or a
    tolerance does not count)."""
    from thermrs.campaigns.engine import rig_identity

    if "rig_hash" not in runs.columns:
        return
    try:
        r, _, digest = rig_identity(rig)
    except InputError:  # a rig not read from a file: nothing to compare with
        return
    other = runs.filter(pl.col("rig_hash") != digest)["recording"].unique().sort().to_list()
    if other:
        shown = ", ".join(other[:4]) + (f", … ({len(other)} recordings)" if len(other) > 4 else "")
        raise InputError(
            f"dataset {dataset.root}: {shown} extracted with another rig than {r.source} (it "
            "would change the numbers): give the rig they were extracted with, or extract "
            "them again with this one (`thermrs extract REC… --rig RIG -o DATASET`)"
        )


@dataclass(frozen=True)
class Fold:
    """One training / held-out split: run names ``<recording>#<run>``."""

    name: str
    train: list[str]
    holdout: list[str]


def folds(runs: pl.DataFrame, rule: str) -> list[Fold]:
    """Training and held-out sets of the selected runs by rule (see the module docs).

    Raises
    ------
    InputError
        An unknown rule, or too few runs (or days) for it.
    """
    names = [f"{r}#{n}" for r, n in zip(runs["recording"], runs["run"], strict=True)]
    if rule == "leave-one-run-out":
        if len(names) < 2:
            raise InputError("leave-one-run-out needs at least two runs")
        return [Fold(f"without {n}", [m for m in names if m != n], [n]) for n in names]
    if rule == "by-day":
        days = sorted(set(runs["date"].to_list()))
        if len(days) < 2:
            raise InputError(
                "by-day needs runs on at least two days (they are all on "
                f"{', '.join(str(d) for d in days)})"
            )
        by_day = {d: [n for n, x in zip(names, runs["date"], strict=True) if x == d] for d in days}
        return [
            Fold(f"train {a}, hold out {b}", by_day[a], by_day[b])
            for a, b in itertools.pairwise(days)
        ]
    raise InputError(f"rule {rule!r}: not one of {', '.join(RULES)}")
