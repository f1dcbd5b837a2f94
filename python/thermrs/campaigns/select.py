"""The runs of a campaign chosen by query, training and held-out sets by rule, and the run
tables that fit, predict, drift and diagnose take.

A query is a comma-separated list of terms ``KEY OP VALUE`` (all must hold), ``OP`` one of
``= != < <= > >=``; keys: ``robot``, ``rig`` (the rig's title, or a rig file: the runs
extracted with that rig), ``recording`` (its catalog id or its file's stem), ``run`` (text),
``date`` (the UTC day the run started: ``YYYY-MM-DD``, ``YYYY/MM/DD``, ``DD.MM.YYYY``, or
``DD/MM/YYYY`` where the day is above 12), ``speed%`` (the speed override, % of the joints'
maximum rates: stated by the run's marker, or estimated from its joint states where the rig
gives the rated maxima; a run whose override is unknown matches no ``speed%`` term),
``speed`` (°/s, the run's 95th-percentile joint speed; see
:func:`thermrs.campaigns.task.run_stats` for both), ``duration`` (s). A value with a comma is
quoted: ``rig="cell 2, KR 15"``. Example: ``robot=KR 15/2, date>=2026-11-02, speed%>=50``.

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

__all__ = [
    "RULES",
    "Fold",
    "campaign_runs",
    "check_rig",
    "folds",
    "parse_date",
    "parse_query",
    "queryable_values",
    "run_tables",
]


def parse_date(text: str) -> date:
    """A day as people type it: ``2026-11-03``, ``2026/11/03``, ``03.11.2026`` (day first),
    ``03/11/2026`` only where it cannot be read the other way round.

    Raises
    ------
    ValueError
        Not a date, or a slashed date whose day and month could be swapped (the message says
        how to write it).
    """
    t = text.strip()
    m = re.fullmatch(r"(\d{4})[-/](\d{1,2})[-/](\d{1,2})", t)
    if m:
        y, mo, d = (int(x) for x in m.groups())
        return date(y, mo, d)
    m = re.fullmatch(r"(\d{1,2})\.(\d{1,2})\.(\d{4})", t)
    if m:
        d, mo, y = (int(x) for x in m.groups())
        return date(y, mo, d)
    m = re.fullmatch(r"(\d{1,2})/(\d{1,2})/(\d{4})", t)
    if m:
        a, b, y = (int(x) for x in m.groups())
        if a > 12 >= b:
            return date(y, b, a)
        if b > 12 >= a:
            return date(y, a, b)
        raise ValueError(
            f"{t!r} could be day/month or month/day: write it as "
            f"{y:04d}-{b:02d}-{a:02d} or {y:04d}-{a:02d}-{b:02d}"
        )
    raise ValueError(f"{t!r} is not a date (write YYYY-MM-DD, e.g. 2026-11-03)")


_KEYS: dict[str, tuple[str, Any]] = {
    "robot": ("robot", str),
    "rig": ("rig", str),
    "recording": ("recording", str),
    "run": ("run", str),
    "date": ("date", parse_date),
    "speed%": ("speed_pct", float),
    "speed": ("speed_deg_s", float),
    "duration": ("duration_s", float),
}
_TERM = re.compile(r"^\s*([a-z]+%?)\s*(<=|>=|!=|=|<|>)\s*(.*?)\s*$")
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
    # Terms split at commas outside double quotes.
    for term in re.split(r',(?=(?:[^"]*"[^"]*")*[^"]*$)', query or ""):
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
        if len(raw) >= 2 and raw[0] == raw[-1] == '"':
            raw = raw[1:-1]
        try:
            value = kind(raw)
        except ValueError as e:
            why = str(e) if kind is parse_date else f"{raw!r} is not a {kind.__name__}"
            raise InputError(f"run query term {term.strip()!r}: {why}") from None
        c = pl.col(col)
        if key == "recording" and op in ("=", "!="):
            # A recording by its catalog id or by its file's stem (the id without its hash).
            c = (
                pl.when(pl.col(col) == value)
                .then(pl.col(col))
                .otherwise(pl.col(col).str.replace(r"-[0-9a-f]{12}$", ""))
            )
        if key == "rig" and op in ("=", "!=") and str(value).endswith(".toml"):
            from thermrs.campaigns.engine import rig_identity

            c, value = pl.col("rig_hash"), rig_identity(str(value))[2]
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
    the catalog (``recording``, ``run``, ``robot``, ``rig``, ``date``, ``speed_pct``,
    ``speed_deg_s``, ``duration_s``, ``start_ns``, ``end_ns``, ``frames``, ``visits``,
    ``losses``), in time order.

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
            f"dataset {dataset.root}: no run matches {query!r} (of {table.height} runs; "
            f"{describe_values(table, query)}; `thermrs campaign DATASET --list` lists them all)"
        )
    return picked


def queryable_values(table: pl.DataFrame) -> dict[str, list[str]]:
    """Every value each query key takes over ``table`` (runs joined with the catalog): text
    keys as their distinct values, numbers as their range."""
    out: dict[str, list[str]] = {}
    for key, (col, kind) in _KEYS.items():
        if col not in table.columns:
            continue
        vals = table[col].drop_nulls()
        if kind is float:
            if len(vals):
                lo, hi = float(vals.min()), float(vals.max())  # type: ignore[arg-type]
                out[key] = [f"{lo:.4g}–{hi:.4g}"]
            else:
                out[key] = []
        else:
            out[key] = sorted({str(v) for v in vals.to_list()})
            if key == "recording":
                out[key] = sorted(
                    {*out[key], *(re.sub(r"-[0-9a-f]{12}$", "", v) for v in out[key])}
                )
    return out


def describe_values(table: pl.DataFrame, query: str | None) -> str:
    """The values the query's keys take (for a query that matched nothing)."""
    keys = [m.group(1) for t in (query or "").split(",") if (m := _TERM.match(t))]
    vals = queryable_values(table)
    parts = []
    for k in dict.fromkeys(keys):
        v = vals.get(k, [])
        shown = ", ".join(v[:8]) + (f", … ({len(v)})" if len(v) > 8 else "")
        parts.append(f"{k}: {shown or 'none'}")
    return "; ".join(parts) or "no key given"


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
