"""A recording followed while it is written (``thermrs watch``): its tables so far, each
update reading only what was added.

The core's follower (``thermrs._native.Follower``) reads the complete MCAP records added since
its last step, through the same walk as :func:`thermrs.extract`; a record still being written
(a chunk half flushed, a footer not there yet) is waited for, never reported lost. A rosbag2
SQLite database (``.db3``, told by its first bytes) is followed by its message rows: each step
reads the committed rows whose ``id`` is above the last read (and the topics added), opened
read-only beside the recorder; a database alone never says it is closed, so a watch of one ends
when it is stopped. A rosbag2 bag folder being recorded is followed part by part:
``NAME_0.mcap``, ``NAME_1.mcap``, … (or ``NAME_0.db3``, …) in order (or the order its
``metadata.yaml`` lists); a part is complete once the next one appears or its footer is
written, the bag once ``metadata.yaml`` is written and lists every part, each complete.

The tables so far are those :func:`thermrs.extract` gives on the bytes read: the columns of
every step appended, then visits and runs found on all of them
(:func:`thermrs.ingest.assemble_tables`), so that on a closed recording they are
:func:`thermrs.extract`'s tables exactly.

A ROS 1 bag or a part compressed whole with zstd is read once it is closed
(:func:`thermrs.extract`); a folder of them is refused with that line.

Example
-------
>>> import thermrs
>>> from thermrs.follow import Follower
>>> f = Follower("live.mcap", thermrs.load_rig())  # doctest: +SKIP
>>> f.step().new_frames  # doctest: +SKIP
120
>>> f.extraction().visits.height  # doctest: +SKIP
40
"""

from __future__ import annotations

import json
import os
import re
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import polars as pl

import thermrs._native as _native
from thermrs.errors import InputError, RecordingError
from thermrs.ingest import Extraction, assemble_tables
from thermrs.rig import Rig, as_rig
from thermrs.rundetect import DEFAULT_GAP_FACTOR, DEFAULT_MIN_GAP_S
from thermrs.visits import DEFAULT_TOLERANCE_DEG

__all__ = ["STATE_KEY", "Follower", "StepResult", "columns_of", "merge_reports"]

#: Parquet key-value metadata key of a watch's follower state (tables of a recording not
#: closed yet, kept so that the watch can go on where it stopped).
STATE_KEY = "thermrs.watch"

Columns = tuple[
    dict[str, np.ndarray], dict[str, np.ndarray], dict[str, np.ndarray], dict[str, np.ndarray]
]

_NUMBERED = re.compile(r"^(?P<stem>.+)_(?P<n>\d+)\.(?:mcap|db3)$")


@dataclass(frozen=True)
class StepResult:
    """What one :meth:`Follower.step` read.

    Attributes
    ----------
    bytes_read
        Bytes of complete records read in this step (every part).
    new_frames
        CCD frames among them.
    closed
        The recording is complete: nothing more will be added.
    """

    bytes_read: int
    new_frames: int
    closed: bool


def merge_reports(a: dict[str, Any], b: dict[str, Any]) -> dict[str, Any]:
    """Two extraction reports (the core's JSON, as dicts) of consecutive byte ranges as one.

    Parameters
    ----------
    a, b
        The reports of the earlier and the later range.

    Returns
    -------
    dict
        Counts summed, losses, metadata records and notes in file order.

    Examples
    --------
    >>> merge_reports({"chunks": 1, "messages": {"/a": 2}}, {"chunks": 2, "messages": {"/a": 1}})[
    ...     "messages"
    ... ]
    {'/a': 3}
    """
    out = dict(a)
    for k, v in b.items():
        if k not in out:
            out[k] = v
        elif k in ("file_bytes", "chunks", "other_messages", "recovered_messages", "crc_failures"):
            out[k] = int(out[k]) + int(v)
        elif k in ("messages", "skipped", "lost_messages"):
            d = dict(out[k])
            for kk, n in v.items():
                d[kk] = int(d.get(kk, 0)) + int(n)
            out[k] = d
        elif k == "skipped_examples":
            out[k] = {**v, **out[k]}
        elif k in ("losses", "metadata", "parts"):
            out[k] = [*out[k], *v]
        elif k == "notes":
            out[k] = [*out[k], *(n for n in v if n not in out[k])]
        elif k == "used_summary":
            out[k] = False
    return out


def columns_of(ex: Extraction, rig: Rig) -> Columns:
    """The core's columns back from an extraction's tables (a watch resumed from its tables).

    Parameters
    ----------
    ex
        Tables :func:`thermrs.extract` or a follower made with ``rig``.
    rig
        That rig.

    Returns
    -------
    tuple
        Frames, thermal, joints and ambient columns as ``thermrs._native.extract`` gives them.
    """
    cams = {c.name: i for i, c in enumerate(rig.cameras)}
    status = {s: i for i, s in enumerate(_native.status_names())}
    f = ex.frames
    frames = {
        "camera": f["camera"].replace_strict(cams, return_dtype=pl.UInt8).to_numpy(),
        "t_ns": f["t_ns"].to_numpy(),
        **{
            k: f[k].cast(pl.Float64).fill_null(np.nan).to_numpy()
            for k in ("x_px", "y_px", "peak", "signal", "size_px", "background", "noise")
        },
        "status": f["status"].replace_strict(status, return_dtype=pl.UInt8).to_numpy(),
    }
    rois = {r.name: i for i, r in enumerate(rig.rois)}
    th = ex.temperatures.filter(pl.col("name") != "ambient")
    thermal = {
        "t_ns": th["t_ns"].to_numpy(),
        "roi": th["name"].replace_strict(rois, return_dtype=pl.UInt16).to_numpy(),
        "max_c": th["temperature_c"].to_numpy(),
        "peak_c": th["peak_c"].to_numpy(),
        "x_px": th["x_px"].cast(pl.Float64).to_numpy(),
        "y_px": th["y_px"].cast(pl.Float64).to_numpy(),
    }
    amb = ex.temperatures.filter(pl.col("name") == "ambient")
    ambient = {"t_ns": amb["t_ns"].to_numpy(), "temperature_c": amb["temperature_c"].to_numpy()}
    j = ex.joints
    joints = {
        "t_ns": j["t_ns"].to_numpy(),
        "position": j.select(rig.joint_names).to_numpy().astype(np.float64).reshape(-1, 6),
    }
    return frames, thermal, joints, ambient


def _concat(parts: list[Columns]) -> Columns:
    """The columns of consecutive steps, appended."""

    def cat(i: int) -> dict[str, np.ndarray]:
        keys = parts[0][i].keys()
        return {k: np.concatenate([p[i][k] for p in parts]) for k in keys}

    return cat(0), cat(1), cat(2), cat(3)


class Follower:
    """Follow a recording while it is written: an MCAP file, a rosbag2 SQLite database or a
    bag folder of MCAP or SQLite parts.

    Parameters
    ----------
    path
        The recording (it may not exist yet: a watch started before the recorder).
    rig
        The rig (a :class:`~thermrs.Rig` or the path of a rig file).
    visit_tolerance_deg, run_gap_factor, run_min_gap_s, min_sigma_px, threshold_sigma
        As for :func:`thermrs.extract`.
    state
        A state from :meth:`state` (a watch resumed), with the tables read so far
        (``resumed``): the follower goes on after the bytes they came from.
    resumed
        The tables read before ``state`` was taken.

    Raises
    ------
    InputError
        A folder that holds ROS 1 bags or parts compressed whole (read them once closed), or a
        state of another recording.
    """

    def __init__(
        self,
        path: str | os.PathLike[str],
        rig: Rig | str | os.PathLike[str],
        *,
        visit_tolerance_deg: float = DEFAULT_TOLERANCE_DEG,
        run_gap_factor: float = DEFAULT_GAP_FACTOR,
        run_min_gap_s: float = DEFAULT_MIN_GAP_S,
        min_sigma_px: float | None = None,
        threshold_sigma: float | None = None,
        state: dict[str, Any] | None = None,
        resumed: Extraction | None = None,
    ) -> None:
        self.path = Path(path)
        self.rig = as_rig(rig)
        self._options = {
            "visit_tolerance_deg": visit_tolerance_deg,
            "run_gap_factor": run_gap_factor,
            "run_min_gap_s": run_min_gap_s,
        }
        self._min_sigma_px = min_sigma_px
        self._threshold_sigma = threshold_sigma
        self._parts: dict[str, _native.Follower] = {}
        self._columns: list[Columns] = []
        self._report: dict[str, Any] = {}
        self._closed = False
        self._bytes = 0
        if state is not None:
            self._resume(state, resumed)

    # -- state ------------------------------------------------------------------------------

    def _resume(self, state: dict[str, Any], resumed: Extraction | None) -> None:
        if state.get("recording") != self.path.name:
            raise InputError(
                f"the tables so far were read from {state.get('recording')!r}, not from "
                f"{self.path.name!r}: give another -o, or the same recording"
            )
        for name, st in state.get("parts", {}).items():
            self._parts[name] = _native.Follower(self._part_path(name), state=json.dumps(st))
        self._report = dict(state.get("report", {}))
        self._bytes = int(state.get("bytes", 0))
        if resumed is not None and resumed.frames.height + resumed.temperatures.height > 0:
            self._columns.append(columns_of(resumed, self.rig))

    def state(self) -> dict[str, Any]:
        """What to keep to go on later (JSON-ready): each part's follower and the report.

        Returns
        -------
        dict
            ``recording`` (the path's name), ``parts`` (per file: the core follower's state),
            ``report`` (what was read so far), ``bytes``.
        """
        return {
            "recording": self.path.name,
            "parts": {n: json.loads(f.state_json()) for n, f in self._parts.items()},
            "report": self._report,
            "bytes": self._bytes,
        }

    # -- reading ----------------------------------------------------------------------------

    def _part_path(self, name: str) -> str:
        return str(self.path / name) if self.path.is_dir() else str(self.path)

    def _files(self) -> tuple[list[str], bool]:
        """The recording's files in order and whether the list is final (a bag's metadata)."""
        if not self.path.is_dir():
            return ([self.path.name] if self.path.exists() else []), True
        others = sorted(p.name for p in self.path.iterdir() if p.suffix in (".bag", ".zstd"))
        if others:
            raise InputError(
                f"recording {self.path}: holds {others[0]}: only MCAP and SQLite (.db3) parts "
                "are followed while written; read a ROS 1 bag or a part compressed whole once "
                "it is closed (thermrs extract)"
            )
        if (self.path / "metadata.yaml").is_file():
            try:
                listed = [Path(p).name for p in _native.bag_parts(str(self.path))]
            except Exception:  # a metadata.yaml being written: the parts as numbered
                listed = []
            if listed:
                return listed, True
        numbered = []
        for p in self.path.iterdir():
            m = _NUMBERED.match(p.name)
            if m:
                numbered.append((int(m["n"]), p.name))
        return [n for _, n in sorted(numbered)], False

    @property
    def closed(self) -> bool:
        """Whether the recording was complete at the last step."""
        return self._closed

    @property
    def bytes_read(self) -> int:
        """Bytes of complete records read so far."""
        return self._bytes

    def step(self, *, progress: Callable[[int, int, int], object] | None = None) -> StepResult:
        """Read what was added since the last step.

        Parameters
        ----------
        progress
            Called as ``progress(bytes_done, bytes_total, frames_done)`` within a large step.

        Returns
        -------
        StepResult
            What the step read, and whether the recording is now complete.

        Raises
        ------
        RecordingError
            A part is not MCAP.
        KeyboardInterrupt
            Ctrl-C (the follower stays where it was).
        """
        files, final = self._files()
        listed = final and self.path.is_dir()  # a bag's metadata.yaml lists every part
        read = frames = 0
        all_closed = bool(files)
        for i, name in enumerate(files):
            f = self._parts.get(name)
            if f is None:
                f = self._parts[name] = _native.Follower(self._part_path(name))
            if f.closed:
                continue
            cols, start, end, closed = f.step(
                self.rig._native,
                progress=progress,
                min_sigma_px=self._min_sigma_px,
                threshold_sigma=self._threshold_sigma,
            )
            if end > start:
                self._columns.append(cols[:4])
                report = json.loads(cols[4])
                self._report = merge_reports(self._report, report) if self._report else report
                read += end - start
                frames += len(cols[0]["t_ns"])
            # A part followed by another is complete once its footer is written; a part still
            # without one while later parts exist is waited for. A SQLite part never says it is
            # closed: rosbag2 closes it before it opens the next part or writes metadata.yaml.
            if name.endswith(".db3"):
                closed = listed or i + 1 < len(files)
            all_closed &= closed
            if not closed and i + 1 < len(files):
                break
        self._bytes += read
        self._closed = final and all_closed
        return StepResult(read, frames, self._closed)

    def extraction(self) -> Extraction:
        """The tables of everything read so far (those of :func:`thermrs.extract` on a closed
        recording).

        Returns
        -------
        Extraction
            Frames, visits, temperatures, joints, runs and the report so far.

        Raises
        ------
        RecordingError
            Nothing of the rig's cameras or thermal camera was read yet.
        """
        if not self._columns:
            raise RecordingError(f"{self.path}: nothing of the rig's topics read yet")
        if len(self._columns) > 1:
            self._columns = [_concat(self._columns)]
        report = {**self._report, "content_hash": None}
        report.setdefault("parts", [])
        ex = assemble_tables(
            self.path,
            self.rig,
            (*self._columns[0], json.dumps(report)),
            **self._options,
        )
        return ex
