"""Visits: one dwell of the robot at a camera's taught pose (SPEC §1).

A frame belongs to a visit when it holds a spot (any status but ``no_spot`` and ``invalid``)
and the latest joint state at or before it is within ``tolerance_deg`` of the camera's taught
pose on every joint. Consecutive such frames of one camera form one visit; any other frame of
that camera in between ends it, and so does a gap of more than ``max_gap_s`` between two of
its frames (cameras that record only at visits have no dark frames between them). Without
any joint states in the recording, every spot frame counts as at the pose (the spot itself
says where the robot is).

Per visit: its run (see :mod:`thermrs.runs`; null when the recording's runs are not given),
its time span and time (the mean of its ``ok`` frames' stamps as an exact integer, its
floor: never rounded through float64), frame counts, the mean centroid over ``ok`` frames and
its scatter (sample standard deviation), in pixels and chip micrometres, and the drift from
the camera's first visit in its run (SPEC §1: drift is anchored at the run's first visit of
each camera).
"""

from __future__ import annotations

import math

import polars as pl

from thermrs.rig import Rig
from thermrs.rundetect import label_runs

__all__ = [
    "DEFAULT_MAX_GAP_S",
    "DEFAULT_TOLERANCE_DEG",
    "anchor_drift",
    "find_visits",
    "with_runs",
]

#: Default joint tolerance (degrees): well above controller jitter, far below a pose change.
DEFAULT_TOLERANCE_DEG = 0.05
#: Default longest pause inside one visit (seconds): frames of a visit come at video rate.
DEFAULT_MAX_GAP_S = 2.0

VISIT_SCHEMA = {
    "run": pl.String,
    "camera": pl.String,
    "visit": pl.Int64,
    "t_start_ns": pl.Int64,
    "t_end_ns": pl.Int64,
    "t_ns": pl.Int64,
    "n_frames": pl.UInt32,
    "n_ok": pl.UInt32,
    "x_px": pl.Float64,
    "y_px": pl.Float64,
    "x_std_px": pl.Float64,
    "y_std_px": pl.Float64,
    "u_um": pl.Float64,
    "v_um": pl.Float64,
    "u_std_um": pl.Float64,
    "v_std_um": pl.Float64,
    "drift_u_um": pl.Float64,
    "drift_v_um": pl.Float64,
}


def find_visits(
    frames: pl.DataFrame,
    joints: pl.DataFrame,
    rig: Rig,
    *,
    tolerance_deg: float = DEFAULT_TOLERANCE_DEG,
    max_gap_s: float = DEFAULT_MAX_GAP_S,
    runs: pl.DataFrame | None = None,
) -> pl.DataFrame:
    """Group spot frames into visits (see the module docstring).

    Parameters
    ----------
    frames
        The frames table of :func:`thermrs.extract` (``camera``, ``t_ns``, ``x_px``, ``y_px``,
        ``u_um``, ``v_um``, ``status``).
    joints
        ``t_ns`` and one column per rig joint name, radians.
    rig
        Gives each camera's taught pose.
    tolerance_deg
        Largest joint deviation from the taught pose, degrees.
    max_gap_s
        Longest pause between two frames of one visit, seconds.
    runs
        The recording's runs table (:mod:`thermrs.runs`): each visit is labelled with the run
        its mean time falls in, and its drift anchored at that run's first visit of its
        camera. Default: no run labels, drift anchored at the recording's first visit.
    """
    if frames.height == 0:
        return pl.DataFrame(schema=VISIT_SCHEMA)
    f = frames.sort("t_ns")
    names = rig.joint_names
    if joints.height:
        f = f.join_asof(joints.sort("t_ns"), on="t_ns", strategy="backward")
        dev = []
        for i, n in enumerate(names):
            taught = {c.name: rig.camera_pose(c.name).joints_deg[i] for c in rig.cameras}
            dev.append(
                (
                    pl.col(n) * (180.0 / math.pi)
                    - pl.col("camera").replace_strict(taught, return_dtype=pl.Float64)
                ).abs()
            )
        at_pose = pl.max_horizontal(dev).fill_null(math.inf) <= tolerance_deg
    else:
        at_pose = pl.lit(True)
    spot = ~pl.col("status").is_in(["no_spot", "invalid"])
    f = (
        f.with_columns(cand=spot & at_pose)
        .sort("camera", "t_ns")
        .with_columns(
            start=pl.col("cand")
            & (
                ~pl.col("cand").shift(1, fill_value=False).over("camera")
                | (pl.col("t_ns").diff().over("camera") > int(max_gap_s * 1e9))
            )
        )
        .with_columns(visit=pl.col("start").cast(pl.Int64).cum_sum().over("camera") - 1)
        .filter("cand")
    )
    ok = pl.col("status") == "ok"
    v = (
        f.group_by("camera", "visit")
        .agg(
            t_start_ns=pl.col("t_ns").min(),
            t_end_ns=pl.col("t_ns").max(),
            t_ns=_integer_mean(pl.col("t_ns").filter(ok)),
            n_frames=pl.len().cast(pl.UInt32),
            n_ok=ok.sum().cast(pl.UInt32),
            x_px=pl.col("x_px").filter(ok).mean(),
            y_px=pl.col("y_px").filter(ok).mean(),
            x_std_px=pl.col("x_px").filter(ok).std(),
            y_std_px=pl.col("y_px").filter(ok).std(),
            u_um=pl.col("u_um").filter(ok).mean(),
            v_um=pl.col("v_um").filter(ok).mean(),
            u_std_um=pl.col("u_um").filter(ok).std(),
            v_std_um=pl.col("v_um").filter(ok).std(),
        )
        .sort("camera", "visit")
    )
    return with_runs(v, runs)


def _integer_mean(t_ns: pl.Expr) -> pl.Expr:
    """The mean of nanosecond stamps as an exact integer (its floor): the stamps' offsets
    from their first, summed in Int64, divided in integers. Never through float64, whose
    spacing at today's epoch stamps is 256 ns: a one-frame visit's time would otherwise land
    up to 128 ns beside its frame, and a window cut at that frame's stamp would lose it.
    Null without stamps."""
    t0 = t_ns.min()
    return t0 + (t_ns - t0).sum() // t_ns.count().cast(pl.Int64)


def with_runs(visits: pl.DataFrame, runs: pl.DataFrame | None) -> pl.DataFrame:
    """The visits labelled with their runs (the run holding each visit's mean time; null
    without ``runs``) and their drift anchored per run (:func:`anchor_drift`)."""
    v = visits
    t_mid = pl.col("t_ns").fill_null((pl.col("t_start_ns") + pl.col("t_end_ns")) // 2)
    if runs is not None and runs.height:
        v = v.with_columns(run=label_runs(v.select(t_mid).to_series(), runs))
    else:
        v = v.with_columns(run=pl.lit(None, dtype=pl.String))
    return anchor_drift(v)


def anchor_drift(visits: pl.DataFrame) -> pl.DataFrame:
    """``drift_u_um``, ``drift_v_um`` of each visit from its camera's first visit (with a
    centroid) in its run (SPEC §1), visits in time order; the columns of the visits table."""
    v = visits.sort("camera", "t_start_ns")
    if "run" not in v.columns:
        v = v.with_columns(run=pl.lit(None, dtype=pl.String))
    key = ["run", "camera"]
    v = v.with_columns(
        drift_u_um=pl.col("u_um") - pl.col("u_um").drop_nulls().first().over(key),
        drift_v_um=pl.col("v_um") - pl.col("v_um").drop_nulls().first().over(key),
    )
    return v.select(list(VISIT_SCHEMA)).cast(VISIT_SCHEMA)  # type: ignore[arg-type]
