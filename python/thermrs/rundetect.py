"""Runs inside a recording, found and labelled (see :mod:`thermrs.runs`, which re-exports
these names and holds the full description): from ``thermrs.run`` run markers when the
recording has any, else from idle gaps between visits.

Pure functions of the recording's Metadata records and visits: nothing here reads a file.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import polars as pl

from thermrs.errors import InputError

__all__ = [
    "DEFAULT_GAP_FACTOR",
    "DEFAULT_MIN_GAP_S",
    "RUNS_SCHEMA",
    "RUN_METADATA",
    "cadence_s",
    "find_runs",
    "label_runs",
    "runs_from_gaps",
    "runs_from_markers",
]

#: Name of the MCAP Metadata record of a run marker (see the Rust ``record::RUN_METADATA``).
RUN_METADATA = "thermrs.run"
#: Idle threshold in visit cadences: a visit gap this many cycles long ends a run.
DEFAULT_GAP_FACTOR = 5.0
#: Shortest idle gap (seconds) that ends a run, whatever the cadence.
DEFAULT_MIN_GAP_S = 600.0

RUNS_SCHEMA: dict[str, Any] = {
    "run": pl.String,
    "start_ns": pl.Int64,
    "end_ns": pl.Int64,
    "source": pl.String,
}


def runs_from_markers(metadata: Sequence[Mapping[str, Any]]) -> pl.DataFrame:
    """The runs the recording's ``thermrs.run`` Metadata records mark, in time order.

    Parameters
    ----------
    metadata
        The file's Metadata records, each ``{"name": str, "values": {str: str}}``
        (:attr:`thermrs.ingest.ExtractReport.metadata`).

    Raises
    ------
    InputError
        A marker without a name, with stamps that are not integers, ending before it starts,
        or two markers of one name.
    """
    rows = []
    for k, m in enumerate(metadata):
        if m.get("name") != RUN_METADATA:
            continue
        v = m.get("values", {})
        try:
            name = str(v["name"])
            start, end = int(v["start_ns"]), int(v["end_ns"])
        except (KeyError, ValueError, TypeError) as e:
            raise InputError(
                f"run marker {k + 1} ({RUN_METADATA} metadata): bad or missing {e}"
            ) from None
        if not name or "#" in name:
            raise InputError(f"run marker {k + 1}: run name {name!r} is empty or contains '#'")
        if end < start:
            raise InputError(f"run marker {name!r}: end_ns {end} before start_ns {start}")
        rows.append({"run": name, "start_ns": start, "end_ns": end, "source": "marker"})
    df = pl.DataFrame(rows, schema=RUNS_SCHEMA).sort("start_ns")
    dup = df.filter(pl.col("run").is_duplicated())["run"].unique().to_list()
    if dup:
        raise InputError(f"run markers: run name(s) {sorted(dup)} marked more than once")
    return df


def cadence_s(visits: pl.DataFrame) -> float:
    """Median time (s) between consecutive visits of one camera; NaN with fewer than two."""
    d = (
        visits.sort("camera", "t_start_ns")
        .select(pl.col("t_start_ns").diff().over("camera").alias("d"))["d"]
        .drop_nulls()
        .to_numpy()
    )
    d = d[d > 0]
    return float(np.median(d)) / 1e9 if len(d) else float("nan")


def runs_from_gaps(
    visits: pl.DataFrame,
    *,
    gap_factor: float = DEFAULT_GAP_FACTOR,
    min_gap_s: float = DEFAULT_MIN_GAP_S,
) -> pl.DataFrame:
    """Split the visits into runs at idle gaps (see the module docstring).

    Parameters
    ----------
    visits
        ``camera``, ``t_start_ns``, ``t_end_ns`` per visit.
    gap_factor
        Idle threshold in cadences.
    min_gap_s
        Shortest idle threshold, seconds.

    Returns
    -------
    polars.DataFrame
        The runs table (``source`` ``"gap"``); empty without visits.
    """
    if gap_factor <= 0 or min_gap_s < 0:
        raise InputError(
            f"gap_factor must be > 0 and min_gap_s ≥ 0 (got {gap_factor}, {min_gap_s})"
        )
    if visits.height == 0:
        return pl.DataFrame(schema=RUNS_SCHEMA)
    cad = cadence_s(visits)
    cad_ns = 0 if not np.isfinite(cad) else int(cad * 1e9)
    threshold_ns = max(min_gap_s * 1e9, gap_factor * cad_ns)
    v = visits.sort("t_start_ns")
    starts = v["t_start_ns"].to_numpy()
    # End of activity so far at each visit (visits of other cameras may overlap).
    ends = np.maximum.accumulate(v["t_end_ns"].to_numpy())
    cut = np.flatnonzero(starts[1:] - ends[:-1] > threshold_ns) + 1
    first = np.concatenate([[0], cut])
    last = np.concatenate([cut - 1, [len(starts) - 1]])
    rows = []
    for k, (i, j) in enumerate(zip(first, last, strict=True)):
        end = int(ends[j]) + cad_ns
        if k + 1 < len(first):
            end = min(end, int(starts[first[k + 1]]) - 1)
        rows.append(
            {"run": f"run{k + 1}", "start_ns": int(starts[i]), "end_ns": end, "source": "gap"}
        )
    return pl.DataFrame(rows, schema=RUNS_SCHEMA)


def find_runs(
    metadata: Sequence[Mapping[str, Any]],
    visits: pl.DataFrame,
    *,
    gap_factor: float = DEFAULT_GAP_FACTOR,
    min_gap_s: float = DEFAULT_MIN_GAP_S,
) -> pl.DataFrame:
    """The recording's runs: from its run markers when it has any, else from idle gaps.

    Visits no marker covers (a recording cut short before its last run's marker was
    written) are split by idle gaps into further runs named ``unmarked1``, … (source
    ``gap``), so that no visit is silently left out.
    """
    marked = runs_from_markers(metadata)
    if marked.height == 0:
        return runs_from_gaps(visits, gap_factor=gap_factor, min_gap_s=min_gap_s)
    if visits.height == 0:
        return marked
    t_mid = visits.select(
        pl.col("t_ns").fill_null((pl.col("t_start_ns") + pl.col("t_end_ns")) // 2)
    ).to_series()
    loose = visits.filter(label_runs(t_mid, marked).is_null())
    if loose.height == 0:
        return marked
    extra = runs_from_gaps(loose, gap_factor=gap_factor, min_gap_s=min_gap_s).with_columns(
        run=pl.lit("unmarked") + pl.int_range(1, pl.len() + 1).cast(pl.String)
    )
    return pl.concat([marked, extra]).sort("start_ns")


def label_runs(t_ns: pl.Series | np.ndarray, runs: pl.DataFrame) -> pl.Series:
    """Per time stamp, the name of the run whose [start_ns, end_ns] holds it (null if none;
    the later run if two overlap).

    Parameters
    ----------
    t_ns
        Time stamps (ns); nulls are labelled null.
    runs
        A runs table (``run``, ``start_ns``, ``end_ns``; :data:`RUNS_SCHEMA`).

    Returns
    -------
    polars.Series
        ``run`` (String), one label per time stamp.

    Notes
    -----
    Built as an index into the run names, never as an object array: whether a time stamp
    lies outside every run (the first joint state of a recording comes before the first
    visit) must not decide the column's type.
    """
    t = (t_ns if isinstance(t_ns, pl.Series) else pl.Series(np.asarray(t_ns))).cast(pl.Int64)
    ordered = runs.sort("start_ns")
    if ordered.height == 0:
        return pl.repeat(None, t.len(), dtype=pl.String, eager=True).alias("run")
    tv = t.fill_null(0).to_numpy()
    valid = t.is_not_null().to_numpy()
    idx = np.full(t.len(), -1, dtype=np.int64)
    for k, (a, b) in enumerate(zip(ordered["start_ns"], ordered["end_ns"], strict=True)):
        idx[valid & (tv >= a) & (tv <= b)] = k
    at = pl.Series(idx).replace(-1, None)
    return ordered["run"].cast(pl.String).gather(at).alias("run")
