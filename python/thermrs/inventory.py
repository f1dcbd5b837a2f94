"""What a recording holds (``thermrs info``), read from its summary and indexes.

No message is decoded: the MCAP summary gives the channels, their message counts, the time
span, the chunks and the Metadata records (run markers among them); the message indexes give
the log times of the CCD topics, from which runs are split at idle gaps when the recording has
no run markers (as :mod:`thermrs.runs` does from the visits; here each burst of one camera's
frames stands for a visit, and log times stand for header stamps). A recording without a
summary (cut short, or written without one) is walked record by record with its chunks left
compressed (see the Rust ``inventory`` module); what could not be read is listed in
``losses``.

Example
-------
>>> import thermrs
>>> inv = thermrs.inventory.inventory("rec.mcap", rig=thermrs.load_rig())  # doctest: +SKIP
>>> inv.runs.select("run", "start_ns", "end_ns", "source")  # doctest: +SKIP
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import polars as pl

import thermrs._native as _native
from thermrs.errors import InputError
from thermrs.rig import Rig, as_rig
from thermrs.runs import (
    DEFAULT_GAP_FACTOR,
    DEFAULT_MIN_GAP_S,
    RUNS_SCHEMA,
    find_runs,
)

__all__ = ["Inventory", "inventory"]

#: Frames of one camera belong to one visit (a burst at the pose) when the spacings between
#: frames are bimodal by at least this factor (within visits and between them).
BURST_FACTOR = 10.0


@dataclass(frozen=True)
class Inventory:
    """What a recording holds.

    Attributes
    ----------
    path
        The recording.
    storage
        How it is stored: ``mcap``, ``sqlite3`` (rosbag2's SQLite), ``ros1``, either of the
        first two with
        `` (zstd file)`` when compressed whole, or ``bag of N files (…)`` for a bag folder
        (its files' inventories summed, channels by topic).
    bytes
        Its size (a bag: its files' sizes summed).
    from_summary
        Whether it was read from its summary section (False: walked record by record).
    start_ns, end_ns
        Log times of its first and last message (None without messages).
    chunks, compression
        How many chunks, and the compressions they use.
    messages
        Messages in all.
    topics
        One row per channel: ``topic``, ``schema``, ``encoding``, ``messages``, ``role``
        (what the rig maps it to, e.g. ``camera A``; empty without a rig or for a topic the
        rig does not read).
    runs
        ``run``, ``start_ns``, ``end_ns``, ``source`` (``marker`` or ``gap``), ``visits``.
    cameras
        With a rig: per camera ``camera``, ``topic``, ``pose``, ``frames`` in the file.
    rois
        With a rig: per thermal ROI ``roi``, ``rect_px``, ``drives`` (the DH lengths it
        expands); ``thermal_frames`` and ``ambient_readings`` give the file's counts.
    losses
        What could not be read, one line each.
    notes
        How the file was read where that is worth saying and nothing was lost (a summary that
        is unreadable or leaves something out, so the data section was read instead).
    metadata
        The Metadata records (``name``, ``values``).
    """

    path: Path
    bytes: int
    from_summary: bool
    profile: str
    library: str
    start_ns: int | None
    end_ns: int | None
    chunks: int
    compression: list[str]
    messages: int
    topics: pl.DataFrame
    runs: pl.DataFrame
    cameras: pl.DataFrame | None
    rois: pl.DataFrame | None
    thermal_frames: int | None
    ambient_readings: int | None
    joint_states: int | None
    losses: list[str]
    metadata: list[dict[str, Any]]
    notes: list[str] = field(default_factory=list)
    storage: str = "mcap"

    @property
    def duration_s(self) -> float:
        """Seconds from the first to the last message (0 without messages)."""
        if self.start_ns is None or self.end_ns is None:
            return 0.0
        return (self.end_ns - self.start_ns) / 1e9

    def to_json(self) -> dict[str, Any]:
        """Everything above as JSON-ready values (``thermrs info --json``)."""
        return {
            "path": str(self.path),
            "storage": self.storage,
            "bytes": self.bytes,
            "from_summary": self.from_summary,
            "profile": self.profile,
            "library": self.library,
            "start_ns": self.start_ns,
            "end_ns": self.end_ns,
            "duration_s": self.duration_s,
            "chunks": self.chunks,
            "compression": self.compression,
            "messages": self.messages,
            "topics": self.topics.to_dicts(),
            "runs": self.runs.to_dicts(),
            "cameras": None if self.cameras is None else self.cameras.to_dicts(),
            "rois": None if self.rois is None else self.rois.to_dicts(),
            "thermal_frames": self.thermal_frames,
            "ambient_readings": self.ambient_readings,
            "joint_states": self.joint_states,
            "losses": self.losses,
            "notes": self.notes,
            "metadata": self.metadata,
        }


def _bursts(times: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Start and end of each burst of frames (one visit each): frames within a visit are
    far closer to each other than visits are (the spacings are bimodal); with one frame per
    visit (spacings alike) every frame is a visit."""
    if len(times) == 0:
        return times, times
    d = np.diff(times).astype(np.float64)
    threshold = 0.0
    if len(d):
        p10, p90 = np.percentile(d, [10, 90])
        if p90 > BURST_FACTOR * max(p10, 1.0):
            threshold = math.sqrt(max(p10, 1.0) * p90)
    cut = np.flatnonzero(d > threshold) + 1
    first = np.concatenate([[0], cut])
    last = np.concatenate([cut - 1, [len(times) - 1]])
    return times[first], times[last]


def _visits(log_times: dict[str, list[int]], topic_camera: dict[str, str]) -> pl.DataFrame:
    rows: dict[str, list[Any]] = {"camera": [], "t_start_ns": [], "t_end_ns": []}
    for topic, times in log_times.items():
        s, e = _bursts(np.asarray(times, dtype=np.int64))
        rows["camera"] += [topic_camera.get(topic, topic)] * len(s)
        rows["t_start_ns"] += s.tolist()
        rows["t_end_ns"] += e.tolist()
    bursts = pl.DataFrame(
        rows, schema={"camera": pl.String, "t_start_ns": pl.Int64, "t_end_ns": pl.Int64}
    )
    # A camera's frames taken while another camera's burst is under way belong to that visit
    # (every camera may record at every pose): a burst inside another camera's is not a visit.
    start = bursts["t_start_ns"].to_numpy()
    end = bursts["t_end_ns"].to_numpy()
    cam = bursts["camera"].to_numpy()
    inside = np.zeros(bursts.height, dtype=bool)
    order = np.argsort(start, kind="stable")
    for k, i in enumerate(order):
        for j in order[k + 1 :]:
            if start[j] > end[i]:
                break
            if cam[j] != cam[i] and end[j] <= end[i] and (start[j], end[j]) != (start[i], end[i]):
                inside[j] = True
    return bursts.filter(~pl.Series(inside)).sort("t_start_ns")


def inventory(
    path: str | os.PathLike[str],
    *,
    rig: Rig | str | os.PathLike[str] | None = None,
    gap_factor: float = DEFAULT_GAP_FACTOR,
    min_gap_s: float = DEFAULT_MIN_GAP_S,
) -> Inventory:
    """What the recording at ``path`` holds (see the module docstring).

    Parameters
    ----------
    path
        A recording: an MCAP file, a rosbag2 SQLite database (``.db3``, read from its tables:
        one pass over the messages' times, their bytes unread), either compressed whole with
        zstd, a ROS 1 bag (format 2.0: from its index, no chunk decompressed), or a rosbag2
        bag folder (its files' inventories summed; a missing file is a loss).
    rig
        The rig it was recorded on (a :class:`~thermrs.Rig` or a rig file), to name each
        topic's role, list the cameras and ROIs it maps, and know which topics are CCD
        frames; without it every ``sensor_msgs/msg/Image`` topic counts.
    gap_factor, min_gap_s
        The idle threshold for runs without markers (see :mod:`thermrs.runs`).

    Raises
    ------
    InputError
        No such file, or a directory that is not a bag.
    RecordingError
        Not a recording thermrs reads (a ROS 1 bag older than format 2.0: the message names
        the conversion), or
        run markers that contradict each other.
    """
    from thermrs.ingest import NOT_A_BAG

    p = Path(path)
    if p.is_dir() and not _native.is_bag(str(p)):
        raise InputError(f"{p}: {NOT_A_BAG}")
    if not p.exists():
        raise InputError(f"{p}: no such file")
    r = as_rig(rig) if rig is not None else None
    topic_camera, role = _roles(r)
    doc = _read(p, r, topic_camera)
    topics = _topics(doc, role)
    counts = dict(zip(topics["topic"].to_list(), topics["messages"].to_list(), strict=True))
    visits = _visits(doc["log_times"], topic_camera)
    runs = _runs(doc, visits, gap_factor=gap_factor, min_gap_s=min_gap_s)
    m = _Mapped.of(r, counts) if r is not None else _Mapped()
    return Inventory(
        path=p,
        bytes=int(doc["bytes"]),
        from_summary=bool(doc["from_summary"]),
        profile=str(doc["profile"]),
        library=str(doc["library"]),
        start_ns=doc["start_ns"],
        end_ns=doc["end_ns"],
        chunks=int(doc["chunks"]),
        compression=list(doc["compression"]),
        messages=int(doc["messages"]),
        topics=topics,
        runs=runs,
        cameras=m.cameras,
        rois=m.rois,
        thermal_frames=m.thermal,
        ambient_readings=m.ambient,
        joint_states=m.joints,
        losses=list(doc["losses"]),
        metadata=list(doc["metadata"]),
        notes=list(doc.get("notes", [])),
        storage=str(doc.get("storage", "mcap")),
    )


def _roles(r: Rig | None) -> tuple[dict[str, str], dict[str, str]]:
    """The rig's camera per CCD topic, and each topic's role (both empty without a rig)."""
    topic_camera: dict[str, str] = {}
    role: dict[str, str] = {}
    if r is not None:
        for c in r.cameras:
            topic_camera[c.topic] = c.name
            role[c.topic] = f"camera {c.name} (pose {c.pose})"
        if r.thermal_topic:
            role[r.thermal_topic] = "thermal camera"
        if r.ambient_topic:
            role[r.ambient_topic] = "ambient temperature"
        role[r.joint_states_topic] = "joint states"
    return topic_camera, role


def _read(p: Path, r: Rig | None, topic_camera: dict[str, str]) -> dict[str, Any]:
    """The core's inventory of ``p``, with the log times of the rig's CCD topics (without a
    rig: of every ``sensor_msgs/msg/Image`` topic)."""
    if r is not None:
        doc: dict[str, Any] = json.loads(_native.inventory(str(p), list(topic_camera)))
        return doc
    probe = json.loads(_native.inventory(str(p), []))
    ccd = [c["topic"] for c in probe["channels"] if c["schema"].endswith("/Image")]
    doc = json.loads(_native.inventory(str(p), ccd)) if ccd else probe
    return doc


def _topics(doc: dict[str, Any], role: dict[str, str]) -> pl.DataFrame:
    """One row per channel: topic, schema, encoding, messages and role."""
    return pl.DataFrame(
        [
            {
                "topic": c["topic"],
                "schema": c["schema"],
                "encoding": c["encoding"],
                "messages": int(c["messages"]),
                "role": role.get(c["topic"], ""),
            }
            for c in doc["channels"]
        ],
        schema={
            "topic": pl.String,
            "schema": pl.String,
            "encoding": pl.String,
            "messages": pl.Int64,
            "role": pl.String,
        },
    )


def _runs(
    doc: dict[str, Any], visits: pl.DataFrame, *, gap_factor: float, min_gap_s: float
) -> pl.DataFrame:
    """The runs as the extraction finds them (markers, and visits no marker covers split by
    idle gaps), with their visits counted."""
    runs = find_runs(
        doc["metadata"],
        visits.with_columns(t_ns=pl.col("t_start_ns")),
        gap_factor=gap_factor,
        min_gap_s=min_gap_s,
    )
    n_visits = [
        visits.filter(pl.col("t_start_ns").is_between(a, b)).height
        for a, b in zip(runs["start_ns"].to_list(), runs["end_ns"].to_list(), strict=True)
    ]
    runs = runs.select(*(pl.col(c).cast(t) for c, t in RUNS_SCHEMA.items()))
    return runs.with_columns(visits=pl.Series(n_visits, dtype=pl.Int64))


@dataclass(frozen=True)
class _Mapped:
    """What the rig maps, counted in the recording (all None without a rig)."""

    cameras: pl.DataFrame | None = None
    rois: pl.DataFrame | None = None
    thermal: int | None = None
    ambient: int | None = None
    joints: int | None = None

    @classmethod
    def of(cls, r: Rig, counts: dict[str, int]) -> _Mapped:
        cameras = pl.DataFrame(
            [
                {
                    "camera": c.name,
                    "topic": c.topic,
                    "pose": c.pose,
                    "frames": counts.get(c.topic, 0),
                }
                for c in r.cameras
            ]
        )
        drives = {
            roi.name: ", ".join(m.name for m in r.lengths if m.temperature == roi.name)
            for roi in r.rois
        }
        rois = pl.DataFrame(
            [{"roi": x.name, "rect_px": list(x.rect_px), "drives": drives[x.name]} for x in r.rois],
            schema={"roi": pl.String, "rect_px": pl.List(pl.Int64), "drives": pl.String},
        )
        return cls(
            cameras=cameras,
            rois=rois,
            thermal=counts.get(r.thermal_topic or "", 0) if r.thermal_topic else None,
            ambient=counts.get(r.ambient_topic or "", 0) if r.ambient_topic else None,
            joints=counts.get(r.joint_states_topic, 0),
        )
