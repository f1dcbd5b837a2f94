"""One recording of a campaign, extracted where a worker runs it.

:func:`run_job` is what the engine maps over the recordings (on Dask workers or in process): it
hashes the file, extracts it (the Rust core releases the GIL), writes its tables into the
dataset's staging folder where the worker sees it (:mod:`thermrs.campaigns.staging`) and
returns its catalog row as plain values; where the worker does not see the folder, it returns
the tables as Arrow tables instead, never polars frames, so that nothing but Arrow buffers and
builtins crosses between processes. Its only side effect is a staged folder that nothing reads
until the client commits it: a job run twice (its worker died and the scheduler ran it again)
leaves an orphan, removed at the campaign's end, and only the client commits.
"""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np
import polars as pl

from thermrs.campaigns.sources import content_hash, recording_id
from thermrs.campaigns.staging import reachable, write_stage
from thermrs.errors import ThermrsError

__all__ = ["RUN_STATS_SCHEMA", "TABLES", "Job", "marker_speeds", "run_job", "run_jobs", "run_stats"]

#: The tables of a recording in a campaign dataset; each is partitioned by recording and run.
TABLES = ("frames", "visits", "temperatures", "joints", "runs")


@dataclass(frozen=True)
class Job:
    """What a worker needs to extract one recording (small, picklable).

    Attributes
    ----------
    path
        The recording.
    rig_text, rig_source
        The rig file's text and where it came from (a worker may not see the client's files).
    rig_hash, thermrs_version
        Written into the catalog row.
    options
        Extraction options as JSON (``{"visit_tolerance_deg": …}``), also written into the
        catalog: a recording extracted with other options is extracted again.
    known
        Content hashes already extracted with this rig, version and options: a file holding
        one of them is not extracted again.
    known_sizes
        The sizes of those files: a file of another size cannot hold their bytes, so it is
        hashed in the extraction's own pass rather than read once more before it.
    stage, token
        The dataset's staging folder and the token file the client left in it: a worker that
        sees the token writes the tables there (empty: always return them).
    """

    path: str
    rig_text: str
    rig_source: str
    rig_hash: str
    thermrs_version: str
    options: str = "{}"
    known: frozenset[str] = frozenset()
    known_sizes: frozenset[int] = frozenset()
    stage: str = ""
    token: str = ""


def run_job(job: Job) -> dict[str, Any]:
    """Hash and extract one recording (the hash first where the file may be one already
    extracted, else in the same pass).

    Returns
    -------
    dict
        ``status``: ``"extracted"`` (with ``row``, the catalog row, and either ``staged``, the
        folder its tables were written into, or ``tables``, name → ``pyarrow.Table`` with a
        ``run`` column), ``"unchanged"`` (its hash is in
        ``job.known``: with ``content_hash`` and ``recording``) or ``"failed"`` (with
        ``error``, one line: the recording is bad input, the campaign goes on).
    """
    from thermrs.ingest import LOSS_KEY, extract
    from thermrs.rig import Rig

    try:
        rig = Rig.from_toml(job.rig_text, source_name=job.rig_source)
        options = json.loads(job.options)
        if _size(job.path) in job.known_sizes:
            # It may hold bytes already extracted (a renamed or touched file): hash first.
            digest = content_hash(job.path)
            if digest in job.known:
                return {
                    "status": "unchanged",
                    "path": job.path,
                    "content_hash": digest,
                    "recording": recording_id(job.path, digest),
                }
            ex = extract(job.path, rig, **options)
        else:
            # No extracted recording has its size, so none has its bytes: the hash is taken
            # in the extraction's own pass (the file is read once).
            ex = extract(job.path, rig, content_hash=True, **options)
            digest = ex.report.content_hash or content_hash(job.path)
        rid = recording_id(job.path, digest)
    except ThermrsError as e:
        return {"status": "failed", "path": job.path, "error": str(e)}
    from thermrs.runs import label_runs

    runs = ex.runs
    tables: dict[str, pl.DataFrame] = {
        "frames": ex.frames.with_columns(run=label_runs(ex.frames["t_ns"], runs)),
        "visits": ex.visits
        if "run" in ex.visits.columns
        else ex.visits.with_columns(run=pl.lit(None, pl.String)),
        "temperatures": ex.temperatures.with_columns(run=label_runs(ex.temperatures["t_ns"], runs)),
        "joints": ex.joints.with_columns(run=label_runs(ex.joints["t_ns"], runs)),
        "runs": run_stats(
            runs,
            ex.frames,
            ex.visits,
            ex.joints,
            metadata=ex.report.metadata,
            max_rate_deg_s=rig.max_rate_deg_s,
        ),
    }
    losses = ex.report.losses
    stamps = [t["t_ns"] for t in (ex.frames, ex.joints, ex.temperatures) if t.height]
    start = min(int(s.min()) for s in stamps) if stamps else None  # type: ignore[arg-type]
    end = max(int(s.max()) for s in stamps) if stamps else None  # type: ignore[arg-type]
    row: dict[str, Any] = {
        "recording": rid,
        "path": job.path,
        "content_hash": digest,
        "size_bytes": ex.report.file_bytes,
        "runs": runs.height,
        "frames": ex.frames.height,
        "visits": ex.visits.height,
        "start_ns": start,
        "end_ns": end,
        "duration_s": (end - start) / 1e9 if start is not None and end is not None else None,
        "rig": rig.name or rig.source,
        "rig_hash": job.rig_hash,
        "robot": rig.model,
        "losses": len(losses),
        "lost_bytes": int(sum(int(x["bytes"]) for x in losses)),
        "loss_detail": json.dumps(losses),
        "crc_failures": ex.report.crc_failures,
        "thermrs_version": job.thermrs_version,
        "options": job.options,
        "extracted_at": datetime.now(UTC).isoformat(timespec="seconds"),
        "report": json.dumps(dataclasses.asdict(ex.report)),
    }
    done = {"status": "extracted", "path": job.path, "row": row}
    if reachable(job.stage, job.token):
        try:
            staged = write_stage(Path(job.stage), rid, tables, {LOSS_KEY: row["loss_detail"]})
            return {**done, "staged": str(staged)}
        except OSError:
            pass  # the client writes them
    return {**done, "tables": {k: v.to_arrow() for k, v in tables.items()}}


def run_jobs(jobs: list[Job]) -> list[dict[str, Any]]:
    """:func:`run_job` on each of a task's recordings, in order (a Dask task holds a run of
    consecutive recordings, :mod:`thermrs.campaigns.split`); their results in that order."""
    return [run_job(j) for j in jobs]


#: Columns of a recording's ``runs`` table in a dataset (:func:`run_stats`; ``recording`` comes
#: from the partition). Datasets written before ``speed_pct`` existed read it as null.
RUN_STATS_SCHEMA: dict[str, Any] = {
    "run": pl.String,
    "start_ns": pl.Int64,
    "end_ns": pl.Int64,
    "source": pl.String,
    "date": pl.Date,
    "duration_s": pl.Float64,
    "frames": pl.Int64,
    "visits": pl.Int64,
    "speed_deg_s": pl.Float64,
    "speed_pct": pl.Float64,
    "speed_pct_source": pl.String,
}


def marker_speeds(metadata: Sequence[Mapping[str, Any]]) -> dict[str, float]:
    """Run name → the speed override (%) its ``thermrs.run`` marker states, for the markers
    that state one (``thermrs simulate`` writes it; other writers may leave it out)."""
    from thermrs.rundetect import RUN_METADATA

    out: dict[str, float] = {}
    for m in metadata:
        v = m.get("values", {})
        if m.get("name") != RUN_METADATA or "speed_pct" not in v:
            continue
        try:
            pct = float(v["speed_pct"])
        except (TypeError, ValueError):
            continue
        if np.isfinite(pct) and pct > 0:
            out[str(v.get("name"))] = pct
    return out


def run_stats(
    runs: pl.DataFrame,
    frames: pl.DataFrame,
    visits: pl.DataFrame,
    joints: pl.DataFrame,
    *,
    metadata: Sequence[Mapping[str, Any]] = (),
    max_rate_deg_s: Sequence[float] | None = None,
) -> pl.DataFrame:
    """The runs table of a recording with what a campaign query needs of each run.

    Columns (:data:`RUN_STATS_SCHEMA`): ``run``, ``start_ns``, ``end_ns``, ``source`` (as
    :func:`thermrs.runs.find_runs`), ``date`` (UTC day of the start), ``duration_s``,
    ``frames``, ``visits``, and how fast the robot moved in the run:

    ``speed_deg_s``
        The 95th percentile of the fastest joint's speed (°/s, from consecutive joint states)
        over the intervals in which it moved (faster than 0.1 °/s; null where it never did).
    ``speed_pct``, ``speed_pct_source``
        The speed override (% of the joints' maximum rates): the one the run's marker states
        (source ``"marker"``, see :func:`marker_speeds`); else, where the rig gives the joints'
        rated maxima (``robot.max_rate_deg_s``), the 95th percentile over the moving intervals
        of the largest joint speed as a fraction of its joint's maximum (source
        ``"joint states"``); else null.
    """
    stated = marker_speeds(metadata)
    rates = np.asarray(max_rate_deg_s, float) if max_rate_deg_s else None
    rows = []
    jt = joints["t_ns"].to_numpy() if joints.height else np.zeros(0, np.int64)
    jq = (
        joints.drop("t_ns").select(pl.all().cast(pl.Float64)).to_numpy()
        if joints.height
        else np.zeros((0, 0))
    )
    for r in runs.iter_rows(named=True):
        a, b = int(r["start_ns"]), int(r["end_ns"])
        inside = (jt >= a) & (jt <= b)
        speed = pct = None
        if inside.sum() >= 2:
            dt = np.diff(jt[inside]) / 1e9
            rate = np.degrees(np.abs(np.diff(jq[inside], axis=0)))
            ok = dt > 0
            v = rate[ok] / dt[ok, None]
            fastest = v.max(axis=1) if v.size else np.zeros(0)
            moving = fastest > 0.1
            if moving.any():
                speed = float(np.percentile(fastest[moving], 95))
                if rates is not None and rates.size == v.shape[1]:
                    share = (v[moving] / rates).max(axis=1)
                    pct = float(100.0 * np.percentile(share, 95))
        source = None
        if r["run"] in stated:
            pct, source = stated[r["run"]], "marker"
        elif pct is not None:
            source = "joint states"
        rows.append(
            {
                **r,
                "date": datetime.fromtimestamp(a / 1e9, UTC).date(),
                "duration_s": (b - a) / 1e9,
                "frames": frames.filter(pl.col("t_ns").is_between(a, b)).height,
                "visits": visits.filter(pl.col("run") == r["run"]).height
                if "run" in visits.columns
                else 0,
                "speed_deg_s": speed,
                "speed_pct": pct,
                "speed_pct_source": source,
            }
        )
    return pl.DataFrame(rows, schema=RUN_STATS_SCHEMA)


def _size(path: str) -> int:
    """The recording's size in bytes (a bag: its files' sizes summed).

    Raises
    ------
    InputError
        The file cannot be read.
    """
    from thermrs.campaigns.sources import stat_of

    return stat_of(Path(path))[0]
