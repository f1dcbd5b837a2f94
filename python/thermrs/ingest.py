"""Extraction of recordings (SPEC §2) into polars tables.

The work is Rust (``thermrs-core``'s ``ingest``, ``cdr``, ``centroid`` and ``thermal``
modules): a memory-mapped, chunk-parallel MCAP walk, zero-copy CDR decoding, spot detection
and sub-pixel centroids, thermal ROI maxima. This module turns the columns into tables, finds
the visits (:mod:`thermrs.visits`) and writes Parquet atomically (:mod:`thermrs.atomic`).

Example
-------
>>> import thermrs
>>> ex = thermrs.extract("kr15-sample.mcap", thermrs.load_rig())  # doctest: +SKIP
>>> ex.frames.filter(status="ok").select("camera", "t_ns", "x_px", "y_px")  # doctest: +SKIP
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import polars as pl

import thermrs._native as _native
from thermrs.atomic import atomic_tmp as atomic_tmp  # atomic writes, importable from here too
from thermrs.atomic import check_writable, write_all, write_parquet_atomic
from thermrs.atomic import publish as publish
from thermrs.errors import InputError, RecordingError
from thermrs.identity import RIG_KEY, rig_identity
from thermrs.rig import Rig, as_rig
from thermrs.rundetect import DEFAULT_GAP_FACTOR, DEFAULT_MIN_GAP_S, RUNS_SCHEMA, find_runs
from thermrs.visits import DEFAULT_TOLERANCE_DEG, find_visits, with_runs

__all__ = [
    "LOSS_KEY",
    "ExtractReport",
    "Extraction",
    "check_writable",
    "data_loss",
    "extract",
    "is_bag",
    "write_parquet_atomic",
]

Progress = Callable[[int, int, int], object]


@dataclass(frozen=True)
class ExtractReport:
    """What an extraction read, skipped and lost.

    Each entry of ``losses`` has ``kind`` (``truncated``, ``corrupt_chunk``,
    ``corrupt_record``, ``undefined_channel`` (messages on a channel the file never defines),
    ``zeros`` (the recording ends in zeros a writer reserved), ``hole`` (a trailing hole the
    file system holds no data for), ``corrupt_database`` (a rosbag2 SQLite database damaged
    part way: the messages before the damage are kept), or for a bag folder ``missing_part``
    and ``unreadable_part`` (a file of the bag, named in ``detail`` and ``part``)),
    ``offset`` and ``bytes`` (the lost byte range is
    ``offset .. offset + bytes``), ``detail`` (one line) and ``messages_lost`` (messages per
    topic the range held, where the file tells: its message indexes, the summary's chunk index
    or the damaged chunk's own records). ``crc_failures`` counts chunks skipped because their
    CRC-32 did not match; ``lost_messages`` sums ``messages_lost`` per topic.
    """

    file_bytes: int
    used_summary: bool
    chunks: int
    messages: dict[str, int]
    other_messages: int
    skipped: dict[str, int]
    skipped_examples: dict[str, str]
    losses: list[dict[str, Any]]
    recovered_messages: int
    frames_by_status: dict[str, int] = field(default_factory=dict)
    #: The file's MCAP Metadata records in file order, each ``{"name": …, "values": {…}}``
    #: (run markers among them, see :mod:`thermrs.runs`).
    metadata: list[dict[str, Any]] = field(default_factory=list)
    crc_failures: int = 0
    lost_messages: dict[str, int] = field(default_factory=dict)
    #: BLAKE3 of the whole file (hex), taken in the extraction's own pass when asked for
    #: (``extract(..., content_hash=True)``), else None.
    content_hash: str | None = None
    #: How the file was read where that is worth saying and nothing was lost (a summary
    #: unreadable; an id defined twice, each message read with the definition before it).
    notes: list[str] = field(default_factory=list)
    #: A bag folder's files in order, each ``{"file", "bytes", "content_hash"}`` (the hash
    #: when asked for, None for a missing file); empty for a single file.
    parts: list[dict[str, Any]] = field(default_factory=list)

    @property
    def data_loss(self) -> bool:
        """Whether any part of the file could not be used (exit code 3 for the CLI)."""
        return bool(self.losses)


@dataclass(frozen=True)
class Extraction:
    """The tables of one recording.

    Attributes
    ----------
    frames
        One row per CCD frame: ``camera``, ``t_ns`` (header stamp), ``x_px``, ``y_px`` (null
        without a spot), ``u_um``, ``v_um`` (chip micrometres about the centre), ``peak``,
        ``signal``, ``size_px``, ``background``, ``noise``, ``status`` (``ok``, ``no_spot``,
        ``saturated``, ``at_border``, ``multiple``, ``streak``, ``invalid``), sorted by camera
        and time.
    visits
        One row per visit (see :func:`thermrs.visits.find_visits`).
    temperatures
        Long format: ``t_ns``, ``name`` (ROI name or ``ambient``), ``temperature_c`` (the ROI
        maximum, SPEC §3), ``peak_c`` (the de-noised peak: the vertex of a quadratic surface
        fitted around the maximum, see the core's ``thermal`` module; the reading itself for
        ambient), ``x_px``, ``y_px`` (where the ROI maximum is; null for ambient).
    joints
        ``t_ns`` and one column per rig joint name (radians).
    report
        What was read, skipped and lost.
    runs
        The runs the recording holds (:mod:`thermrs.runs`): ``run``, ``start_ns``, ``end_ns``,
        ``source`` (``marker`` or ``gap``); the visits' ``run`` column names them.
    rig
        The identity of the rig the tables were extracted with
        (:func:`thermrs.identity.rig_identity`: its digest and extraction map); written
        with the tables, so that a later command refuses a rig with other cameras or ROIs.
    """

    frames: pl.DataFrame
    visits: pl.DataFrame
    temperatures: pl.DataFrame
    joints: pl.DataFrame
    report: ExtractReport
    runs: pl.DataFrame = field(default_factory=lambda: pl.DataFrame(schema=RUNS_SCHEMA))
    rig: dict[str, Any] | None = None

    def write(self, out: str | Path, *, metadata: dict[str, str] | None = None) -> dict[str, Path]:
        """Write every table, each atomically.

        Parameters
        ----------
        out
            The frames file (``OUT.parquet``); the other tables go beside it as
            ``OUT.visits.parquet``, ``OUT.temperatures.parquet``, ``OUT.joints.parquet`` and
            ``OUT.runs.parquet``.
            Its folder must exist.
        metadata
            More Parquet key-value metadata for every table (a watch's follower state).

        Returns
        -------
        dict[str, Path]
            ``{"frames", "visits", "temperatures", "joints", "runs"}`` → the paths written.

        Raises
        ------
        InputError
            The folder does not exist.
        OutputError
            A file cannot be written there (naming it); nothing this call wrote is left.

        Notes
        -----
        Every table carries the recording's losses (a file cut short, a corrupt chunk) in its
        Parquet key-value metadata under :data:`LOSS_KEY`, so that the loss follows the tables
        to every later command (:func:`data_loss` reads it back), and the identity of the rig
        they were extracted with under :data:`thermrs.identity.RIG_KEY` (JSON), so that a
        command given another rig refuses them (:func:`thermrs.identity.check_rig`).
        """
        out = Path(out)
        stem = out.name[: -len(".parquet")] if out.name.endswith(".parquet") else out.name
        paths = {
            "frames": out,
            "visits": out.with_name(f"{stem}.visits.parquet"),
            "temperatures": out.with_name(f"{stem}.temperatures.parquet"),
            "joints": out.with_name(f"{stem}.joints.parquet"),
            "runs": out.with_name(f"{stem}.runs.parquet"),
        }
        meta = {LOSS_KEY: json.dumps(self.report.losses)}
        if self.rig is not None:
            meta[RIG_KEY] = json.dumps(self.rig)
        meta.update(metadata or {})
        # All or nothing: every table to a temporary file first, then the renames; an error or
        # Ctrl-C on the way removes what this call wrote.
        write_all({path: self._parquet_writer(name, meta) for name, path in paths.items()})
        return paths

    def _parquet_writer(self, name: str, meta: dict[str, str]) -> Callable[[Path], None]:
        table: pl.DataFrame = getattr(self, name)
        return lambda tmp: table.write_parquet(tmp, metadata=meta)


#: Why a folder is not read as one recording.
NOT_A_BAG = (
    "is a directory but not a rosbag2 bag (no metadata.yaml, and its recordings are not the "
    "numbered files NAME_0, NAME_1, … of one bag); give a recording (.mcap, .db3) or a bag folder"
)


def is_bag(path: str | os.PathLike[str]) -> bool:
    """Whether ``path`` is a folder read as one recording: a rosbag2 bag (``metadata.yaml``),
    or numbered files ``NAME_0``, ``NAME_1``, … of one recording split, holding the same topics
    and following each other in time.

    Parameters
    ----------
    path
        Any path (a file or a missing path is not a bag).

    Returns
    -------
    bool
        True for a bag folder.

    Raises
    ------
    InputError
        Never for a path that cannot be read: that is not a bag.

    Examples
    --------
    >>> import thermrs.ingest
    >>> thermrs.ingest.is_bag("no-such-folder")
    False
    """
    return _native.is_bag(os.fspath(path))


#: Parquet key-value metadata key of the losses of the recording a table was extracted from
#: (a JSON list of ``{"kind", "offset", "bytes", "detail"}``; empty when nothing was lost).
LOSS_KEY = "thermrs.data_loss"


def data_loss(path: str | Path) -> list[dict[str, Any]]:
    """The losses of the recording a table written by :meth:`Extraction.write` came from.

    Parameters
    ----------
    path
        A Parquet file written by :meth:`Extraction.write` (or ``thermrs extract``).

    Returns
    -------
    list[dict]
        One ``{"kind", "offset", "bytes", "detail"}`` per loss; empty when nothing was lost or
        the file carries no record of it.

    Raises
    ------
    InputError
        The file cannot be read as Parquet.

    Examples
    --------
    >>> from thermrs.ingest import data_loss
    >>> data_loss("run.visits.parquet")  # doctest: +SKIP
    [{'kind': 'truncated', 'offset': 1048576, 'bytes': 5120, 'detail': '...'}]
    """
    try:
        meta = pl.read_parquet_metadata(path)
    except (OSError, pl.exceptions.PolarsError) as e:
        raise InputError(f"{path}: cannot read its Parquet metadata: {e}") from None
    raw = meta.get(LOSS_KEY)
    if not raw:
        return []
    try:
        losses = json.loads(raw)
    except ValueError:
        return [{"kind": "unknown", "offset": 0, "bytes": 0, "detail": str(raw)}]
    return [x for x in losses if isinstance(x, dict)] if isinstance(losses, list) else []


def extract(
    path: str | Path,
    rig: Rig | str | os.PathLike[str],
    *,
    progress: Progress | None = None,
    visit_tolerance_deg: float = DEFAULT_TOLERANCE_DEG,
    min_sigma_px: float | None = None,
    threshold_sigma: float | None = None,
    run_gap_factor: float = DEFAULT_GAP_FACTOR,
    run_min_gap_s: float = DEFAULT_MIN_GAP_S,
    verify_crc: bool = True,
    content_hash: bool = False,
) -> Extraction:
    """Extract every table of a recording.

    Parameters
    ----------
    path
        The recording: an MCAP file, a rosbag2 SQLite database (``.db3``), either compressed
        whole with zstd (``.zstd``), a ROS 1 bag (format 2.0), or a rosbag2 bag folder
        (``metadata.yaml`` and its files, read in the order it lists them as one recording:
        runs and visits cross the files' boundaries; a file missing or unreadable is a loss).
        What a file holds is recognised by its first bytes.
    rig
        The rig that names its topics, cameras, ROIs and poses (a :class:`~thermrs.Rig` or the
        path of a rig file).
    progress
        Called as ``progress(bytes_done, bytes_total, frames_done)`` between windows.
    visit_tolerance_deg
        How far (degrees, every joint) the joint states may be from a camera's taught pose for
        a spot frame to count as part of a visit.
    min_sigma_px, threshold_sigma
        Spot detection: smallest spot σ to be sure to find, threshold in noise σ.
    run_gap_factor, run_min_gap_s
        Without run markers, a recording splits into runs where no camera is visited for
        longer than ``max(run_min_gap_s, run_gap_factor × visit cadence)`` (see
        :mod:`thermrs.runs`).
    verify_crc
        Check each chunk's CRC-32 where the writer stored one; a chunk that fails is skipped
        and reported as a loss (default). ``False`` trusts the chunks (benchmarks).
    content_hash
        Also hash the whole file (BLAKE3, ``report.content_hash``) in the same pass, so that
        the file is read once for both (campaigns).

    Returns
    -------
    Extraction
        The frames, visits, temperatures and joints tables and the report of what was read,
        skipped and lost (``report.data_loss``: part of the file could not be used).

    Raises
    ------
    RecordingError
        Not a recording thermrs reads (a ROS 1 bag older than format 2.0: the message names
        the conversion), or
        none of the rig's topics in it, or none of its camera topics (the recording was made
        on another rig); the message names the topics.
    InternalError
        A bug in thermrs (a panic in the core), as one line.
    InputError
        The file does not exist, is a directory but not a bag, or cannot be read.
    TypeError
        ``rig`` is neither a :class:`~thermrs.Rig` nor a path.
    KeyboardInterrupt
        Ctrl-C (checked between windows of chunks).

    Examples
    --------
    >>> import thermrs
    >>> ex = thermrs.extract("kr15-sample.mcap", "kr15-paper.toml")  # doctest: +SKIP
    >>> ex.frames.filter(status="ok").height, ex.report.data_loss  # doctest: +SKIP
    (2880, False)
    """
    rig = as_rig(rig)
    p = Path(path)
    if p.is_dir() and not is_bag(p):
        raise InputError(f"recording {p}: {NOT_A_BAG}")
    if not p.exists():
        raise InputError(f"recording {p}: no such file")
    columns = _native.extract(
        str(path),
        rig._native,
        progress=progress,
        min_sigma_px=min_sigma_px,
        threshold_sigma=threshold_sigma,
        verify_crc=verify_crc,
        content_hash=content_hash,
    )
    return assemble_tables(
        p,
        rig,
        columns,
        visit_tolerance_deg=visit_tolerance_deg,
        run_gap_factor=run_gap_factor,
        run_min_gap_s=run_min_gap_s,
    )


def assemble_tables(
    path: Path,
    rig: Rig,
    columns: tuple[
        dict[str, np.ndarray],
        dict[str, np.ndarray],
        dict[str, np.ndarray],
        dict[str, np.ndarray],
        str,
    ],
    *,
    visit_tolerance_deg: float = DEFAULT_TOLERANCE_DEG,
    run_gap_factor: float = DEFAULT_GAP_FACTOR,
    run_min_gap_s: float = DEFAULT_MIN_GAP_S,
) -> Extraction:
    """The tables of :func:`extract` from the core's columns (``thermrs._native.extract``).

    Parameters
    ----------
    path
        The recording the columns came from (named in errors).
    rig
        The rig they were extracted with.
    columns
        The core's frames, thermal, joints and ambient columns and its report (JSON).
    visit_tolerance_deg, run_gap_factor, run_min_gap_s
        As for :func:`extract`.

    Returns
    -------
    Extraction
        As :func:`extract` returns it.

    Raises
    ------
    RecordingError
        None of the rig's camera or thermal topics was read (see :func:`extract`).
    """
    frames_c, thermal_c, joints_c, ambient_c, report_json = columns
    frames = _frames_table(frames_c, rig)
    temperatures = _temperatures_table(thermal_c, ambient_c, rig)
    pos = joints_c["position"]
    joints = pl.DataFrame(
        {"t_ns": joints_c["t_ns"], **{n: pos[:, i] for i, n in enumerate(rig.joint_names)}},
        schema_overrides={"t_ns": pl.Int64},
    ).sort("t_ns")

    rep = json.loads(report_json)
    _check_rig_matches(path, rig, rep)
    counts = frames.group_by("status").len().sort("status")
    report = ExtractReport(
        **rep,
        frames_by_status=dict(zip(counts["status"], counts["len"], strict=True)),
    )
    visits = find_visits(frames, joints, rig, tolerance_deg=visit_tolerance_deg)
    runs = find_runs(report.metadata, visits, gap_factor=run_gap_factor, min_gap_s=run_min_gap_s)
    visits = with_runs(visits, runs)
    return Extraction(
        frames=frames,
        visits=visits,
        temperatures=temperatures,
        joints=joints,
        report=report,
        runs=runs,
        rig=rig_identity(rig),
    )


def _labels(names: list[str], codes: np.ndarray) -> pl.Series:
    """Names for the core's integer codes (camera, status, ROI), as a string column."""
    if not len(codes):
        return pl.Series([], dtype=pl.String)
    return pl.Series(np.asarray(names, dtype=object)[codes], dtype=pl.String)


def _frames_table(frames_c: dict[str, np.ndarray], rig: Rig) -> pl.DataFrame:
    """The frames table from the core's columns: names for codes, chip µm, nulls for no spot."""
    frames = pl.DataFrame(
        {k: v for k, v in frames_c.items() if k not in ("camera", "status")}
    ).with_columns(
        camera=_labels([c.name for c in rig.cameras], frames_c["camera"]),
        status=_labels(_native.status_names(), frames_c["status"]),
    )
    # No spot (or an invalid frame): null, not NaN, in every measured column.
    frames = frames.with_columns(pl.col(pl.Float64).fill_nan(None))
    frames = _with_chip_um(frames, rig).sort("camera", "t_ns")
    return frames.select(
        "camera",
        "t_ns",
        "x_px",
        "y_px",
        "u_um",
        "v_um",
        "status",
        "peak",
        "signal",
        "size_px",
        "background",
        "noise",
    )


def _temperatures_table(
    thermal_c: dict[str, np.ndarray], ambient_c: dict[str, np.ndarray], rig: Rig
) -> pl.DataFrame:
    """ROI maxima and peaks beside the ambient readings, one row per reading."""
    thermal = pl.DataFrame(
        {
            "t_ns": thermal_c["t_ns"],
            "name": _labels([r.name for r in rig.rois], thermal_c["roi"]),
            "temperature_c": thermal_c["max_c"],
            "peak_c": thermal_c["peak_c"],
            "x_px": thermal_c["x_px"].astype(np.int32),
            "y_px": thermal_c["y_px"].astype(np.int32),
        },
        schema_overrides={"t_ns": pl.Int64},
    )
    n = len(ambient_c["t_ns"])
    ambient = pl.DataFrame(
        {
            "t_ns": ambient_c["t_ns"],
            "name": pl.Series(["ambient"] * n, dtype=pl.String),
            "temperature_c": ambient_c["temperature_c"],
            "peak_c": ambient_c["temperature_c"],
            "x_px": pl.Series([None] * n, dtype=pl.Int32),
            "y_px": pl.Series([None] * n, dtype=pl.Int32),
        },
        schema_overrides={"t_ns": pl.Int64},
    )
    return pl.concat([thermal, ambient]).sort("t_ns", "name")


def _check_rig_matches(path: Path, rig: Rig, rep: dict[str, Any]) -> None:
    """SPEC §2: a recording with none of the rig's topics is an error naming them. The joint
    and ambient topics are generic (``/joint_states``), so a recording that has neither a
    camera topic nor the thermal topic of the rig was made on another rig."""
    sensors = [c.topic for c in rig.cameras] + ([rig.thermal_topic] if rig.thermal_topic else [])
    read = {t for t, n in rep.get("messages", {}).items() if n}
    if read & set(sensors):
        return
    matched = sorted(read)
    raise RecordingError(
        f"{path}: none of the rig's camera topics ({', '.join(sensors)}) is in the recording"
        + (f"; it matches only {', '.join(matched)}" if matched else "")
        + f" and has {rep.get('other_messages', 0):,} messages on other topics"
        + f" (was it recorded on another rig than {rig.source}?)"
    )


def _with_chip_um(frames: pl.DataFrame, rig: Rig) -> pl.DataFrame:
    """Add u_um, v_um (SPEC §4 chip micrometres about the centre) per camera."""
    cx = {c.name: (c.size_px[0] - 1) / 2 for c in rig.cameras}
    cy = {c.name: (c.size_px[1] - 1) / 2 for c in rig.cameras}
    px = {c.name: c.pixel_pitch_um[0] for c in rig.cameras}
    py = {c.name: c.pixel_pitch_um[1] for c in rig.cameras}
    cam = pl.col("camera")
    return frames.with_columns(
        u_um=(pl.col("x_px") - cam.replace_strict(cx, return_dtype=pl.Float64))
        * cam.replace_strict(px, return_dtype=pl.Float64),
        v_um=(pl.col("y_px") - cam.replace_strict(cy, return_dtype=pl.Float64))
        * cam.replace_strict(py, return_dtype=pl.Float64),
    )


def stat_of(path: Path) -> tuple[int, int]:
    """Size and modification time (ns) of a recording: a file's own; a bag's files' sizes
    summed and the latest modification of them and its ``metadata.yaml``.

    Raises
    ------
    InputError
        It cannot be read.
    """
    from thermrs.errors import ThermrsError

    try:
        if not path.is_dir():
            st = path.stat()
            return st.st_size, st.st_mtime_ns
        try:
            parts = [Path(p) for p in _native.bag_parts(str(path))]
        except ThermrsError as e:
            raise InputError(str(e)) from None
        stats = [p.stat() for p in parts if p.is_file()]
        meta = path / "metadata.yaml"
        mtimes = [s.st_mtime_ns for s in stats] + (
            [meta.stat().st_mtime_ns] if meta.is_file() else []
        )
        return sum(s.st_size for s in stats), max(mtimes, default=path.stat().st_mtime_ns)
    except OSError as e:
        raise InputError(f"recording {path}: {e.strerror or e}") from None
