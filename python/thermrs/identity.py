"""What a table, a diagnosis or a law belongs to: the rig it was made with, the runs it was
made on.

Extracted tables carry the rig's *extraction map* (:func:`extraction_map`: the topics read,
each camera's taught pose and pixel grid, the thermal ROIs: everything extraction reads the
recording with) and the rig's digest (:func:`rig_digest`) in their Parquet key-value
metadata under :data:`RIG_KEY`; a diagnosis carries the same identity of its rig and a
digest of each of its runs' content (:func:`run_digests`); a compensation law carries its
rig's identity.

A rig is refused for them (:func:`check_rig`) when its map differs: a camera it lacks, a
camera on another topic, at another taught pose or with another pixel grid, other ROIs or
thermal scaling. A rig that differs only in comments, ``[tolerances]``, link lengths or chip
geometry is accepted: the tables are what that rig would have extracted too, and analysing
them with re-measured geometry is what a user checking a rig does. So is a rig with more
cameras (a design's ``rig.toml``, the rig plus a new chip): the tables lack the new camera, as
a recording made before it does.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import polars as pl

from thermrs.errors import InputError
from thermrs.rig import Rig

__all__ = [
    "RIG_KEY",
    "check_rig",
    "extraction_map",
    "mismatch",
    "rig_digest",
    "rig_identity",
    "run_digest",
    "run_digests",
]

#: Parquet key-value metadata key of the identity of the rig a table was extracted with
#: (JSON: :func:`rig_identity`).
RIG_KEY = "thermrs.rig"


def rig_digest(rig: Rig) -> str:
    """BLAKE3 (hex) of the validated rig as JSON, ``[tolerances]`` left out: two files of
    one rig (comments, key order, tolerances aside) digest alike. The digest a campaign
    catalog keeps as ``rig_hash``."""
    from blake3 import blake3

    data = rig.to_dict()
    data.pop("tolerances", None)
    return blake3(json.dumps(data, separators=(",", ":")).encode()).hexdigest()


def extraction_map(rig: Rig) -> dict[str, Any]:
    """What extraction reads a recording with: topics, joint names, cameras (name, topic,
    taught pose, pixel grid), thermal scaling and ROIs, as plain data."""
    return {
        "joint_states_topic": rig.joint_states_topic,
        "joint_names": list(rig.joint_names),
        "cameras": [
            {
                "name": c.name,
                "topic": c.topic,
                "pose_joints_deg": list(rig.poses[c.pose].joints_deg),
                "size_px": list(c.size_px),
                "pixel_pitch_um": list(c.pixel_pitch_um),
            }
            for c in rig.cameras
        ],
        "thermal": None
        if rig.thermal_topic is None
        else {
            "topic": rig.thermal_topic,
            "size_px": list(rig.thermal_size_px or ()),
            "scale": rig.thermal_scale,
            "offset_c": rig.thermal_offset_c,
            "rois": [{"name": r.name, "rect_px": list(r.rect_px)} for r in rig.rois],
        },
        "ambient_topic": rig.ambient_topic,
    }


def rig_identity(rig: Rig) -> dict[str, Any]:
    """The identity a table, a diagnosis or a law carries of its rig: ``name``, ``model``,
    ``digest`` (:func:`rig_digest`) and ``map`` (:func:`extraction_map`)."""
    return {
        "name": rig.name,
        "model": rig.model,
        "digest": rig_digest(rig),
        "map": extraction_map(rig),
    }


def _names(items: Iterable[Mapping[str, Any]]) -> str:
    return ", ".join(str(i["name"]) for i in items) or "none"


def mismatch(theirs: Mapping[str, Any], rig: Rig) -> str | None:
    """The first way the extraction map ``theirs`` differs from ``rig``'s, in words (None:
    the same map)."""
    ours = extraction_map(rig)
    if theirs == ours:
        return None
    t_cams = list(theirs.get("cameras") or [])
    o_cams = ours["cameras"]
    # A rig with more cameras is the same rig grown (a design's rig.toml: a new chip beside
    # the old ones): the tables simply lack the new camera.
    if not {c["name"] for c in t_cams} <= {c["name"] for c in o_cams}:
        return f"cameras {_names(t_cams)}, where the rig has {_names(o_cams)}"
    by_name = {c["name"]: c for c in o_cams}
    words = {
        "topic": "topic",
        "pose_joints_deg": "taught pose (joints, degrees)",
        "size_px": "chip size (pixels)",
        "pixel_pitch_um": "pixel pitch (µm)",
    }
    for c in t_cams:
        o = by_name[c["name"]]
        for k, w in words.items():
            if c.get(k) != o[k]:
                return f"camera {c['name']}'s {w} {c.get(k)}, where the rig has {o[k]}"
    t_th, o_th = theirs.get("thermal"), ours["thermal"]
    if (t_th is None) != (o_th is None):
        return (
            "no thermal camera, where the rig has one"
            if t_th is None
            else "a thermal camera, where the rig has none"
        )
    if t_th is not None and o_th is not None:
        t_rois, o_rois = list(t_th.get("rois") or []), o_th["rois"]
        if sorted(r["name"] for r in t_rois) != sorted(r["name"] for r in o_rois):
            return f"ROIs {_names(t_rois)}, where the rig has {_names(o_rois)}"
        rects = {r["name"]: r["rect_px"] for r in o_rois}
        for r in t_rois:
            if r.get("rect_px") != rects[r["name"]]:
                return (
                    f"ROI {r['name']} at {r.get('rect_px')}, where the rig has it at "
                    f"{rects[r['name']]}"
                )
        for k in ("topic", "size_px", "scale", "offset_c"):
            if t_th.get(k) != o_th[k]:
                return f"thermal {k} {t_th.get(k)}, where the rig has {o_th[k]}"
    for k in ("joint_states_topic", "joint_names", "ambient_topic"):
        if theirs.get(k) != ours[k]:
            return f"{k.replace('_', ' ')} {theirs.get(k)}, where the rig has {ours[k]}"
    return None


def check_rig(
    what: str,
    rig: Rig,
    identity: Mapping[str, Any] | None,
    *,
    cameras: Iterable[str] = (),
    temperatures: Iterable[str] = (),
    fix: str = "",
    made: str = "made",
) -> None:
    """Raise :class:`InputError` (one line) unless ``what`` was made with ``rig``'s
    extraction map.

    Parameters
    ----------
    what
        What is checked, as the message names it (a table's path, ``--diagnosis D.json``).
    rig
        The rig it is analysed with.
    identity
        Its rig's identity (:func:`rig_identity`), or None when it carries none (tables and
        diagnoses made before it was recorded): then only the names are checked.
    cameras, temperatures
        The camera and temperature names it holds, checked against the rig's cameras and
        ROIs (and ``ambient``) when it carries no identity.
    fix
        What to do about it, appended to the message.
    made
        How it was made with its rig (``"extracted"`` for tables).
    """
    tail = f": {fix}" if fix else ""
    head = f"{what}: {made} with another rig than {rig.source}"
    if identity is not None and isinstance(identity.get("map"), Mapping):
        why = mismatch(identity["map"], rig)
        if why is not None:
            raise InputError(f"{head} ({why}){tail}")
        return
    known = {c.name for c in rig.cameras}
    other = sorted(set(cameras) - known)
    if other:
        raise InputError(
            f"{head} (cameras {', '.join(other)}, where the rig has "
            f"{', '.join(c.name for c in rig.cameras)}){tail}"
        )
    names = {r.name for r in rig.rois} | {"ambient"}
    other = sorted(set(temperatures) - names)
    if other:
        shown = ", ".join(r.name for r in rig.rois) or "none"
        raise InputError(f"{head} (ROIs {', '.join(other)}, where the rig has {shown}){tail}")


def run_digest(table: pl.DataFrame) -> str:
    """A digest (BLAKE2b, hex) of a run table's content: its columns' names, types, values
    and nulls, whatever its memory layout, but not its ``run`` label (the same run named by a
    campaign's recording id or by its file digests alike; names are compared on their own).
    Numbers are digested by their bytes, text by its UTF-8: the same table read again, by
    this or another process, digests alike."""
    h = hashlib.blake2b(digest_size=16)
    t = table.rechunk()
    for name in t.columns:
        if name == "run":
            continue
        s = t[name]
        h.update(f"{name}\0{s.dtype}\0{s.len()}\0".encode())
        h.update(s.is_null().to_numpy().tobytes())
        if s.dtype.is_numeric() or s.dtype == pl.Boolean:
            filled = s.fill_null(0) if s.null_count() else s
            h.update(filled.to_numpy().tobytes())
        else:
            for v in s.cast(pl.String).to_list():
                h.update(b"\1" if v is None else v.encode() + b"\0")
    return h.hexdigest()


def run_digests(tables: Sequence[pl.DataFrame]) -> dict[str, str]:
    """Per run (its ``run`` label), the digest of its table (:func:`run_digest`)."""
    out: dict[str, str] = {}
    for t in tables:
        names = t["run"].unique().to_list() if "run" in t.columns and t.height else []
        out[str(names[0]) if len(names) == 1 else f"#{len(out)}"] = run_digest(t)
    return out
