"""Rig files the tests and fixtures write: where the UR5 fixture lies, and the one rig-TOML
template (:func:`rig_toml`) that fixtures/make_ur5_rig.py (the UR5 fixture) and
:func:`tests.support.coverage.random_rig` (random KR 16-like rigs) fill in: a six-axis arm, a
laser, chip cameras placed where the laser meets them at their poses, a 160×120 thermal camera
with two ROIs, and lengths mapped to temperatures.

Only numpy and the standard library: fixtures/make_ur5_rig.py imports this module as a script,
without thermrs."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[2]
UR5 = REPO / "fixtures" / "rigs" / "ur5-two-cameras.toml"

#: One DH row: a_mm, alpha_deg, d_mm, theta_offset_deg, sign.
DhRow = tuple[float, float, float, float, int]


def fmt(v: np.ndarray | Sequence[float]) -> str:
    """A TOML array of floats, each written exactly (``repr``)."""
    return "[" + ", ".join(repr(float(c)) for c in v) + "]"


def camera(
    name: str,
    topic: str,
    pose: str,
    centre_mm: np.ndarray | Sequence[float],
    x_axis: np.ndarray | Sequence[float],
    y_axis: np.ndarray | Sequence[float],
    pixel_pitch_um: tuple[float, float],
    size_px: tuple[int, int],
) -> str:
    """One ``[[camera]]`` table."""
    return (
        f'[[camera]]\nname = "{name}"\ntopic = "{topic}"\npose = "{pose}"\n'
        f"centre_mm = {fmt(centre_mm)}\nx_axis = {fmt(x_axis)}\ny_axis = {fmt(y_axis)}\n"
        f"pixel_pitch_um = {fmt(pixel_pitch_um)}\nsize_px = [{size_px[0]}, {size_px[1]}]\n"
    )


def pose(name: str, joints_deg: np.ndarray | Sequence[float]) -> str:
    """One ``[[pose]]`` table."""
    return f'[[pose]]\nname = "{name}"\njoints_deg = {fmt(joints_deg)}\n'


def rig_toml(
    *,
    name: str,
    model: str,
    joint_names: Sequence[str],
    dh: Sequence[DhRow],
    laser_origin_mm: np.ndarray | Sequence[float],
    laser_direction: np.ndarray | Sequence[float],
    cameras: Sequence[str],
    poses: Sequence[str],
    rois: tuple[str, str],
    lengths: Sequence[tuple[str, str]],
    ambient_topic: str | None = None,
) -> str:
    """The rig file: ``cameras`` and ``poses`` as :func:`camera` and :func:`pose` write them;
    ``rois`` name the thermal camera's two ROIs (rectangles [10, 10, 60, 40] and
    [70, 20, 150, 50]); ``lengths`` are (DH length, temperature) pairs; an ``[ambient]`` table
    only with ``ambient_topic``."""
    names = ", ".join(f'"{n}"' for n in joint_names)
    rows = "\n".join(
        f"    {{ a_mm = {a!r}, alpha_deg = {al}, d_mm = {d!r}, theta_offset_deg = {off}, "
        f"sign = {s} }},"
        for a, al, d, off, s in dh
    )
    ambient = f'[ambient]\ntopic = "{ambient_topic}"\n\n' if ambient_topic is not None else ""
    length = "\n".join(f'    {{ name = "{n}", temperature = "{t}" }},' for n, t in lengths)
    return f"""format = "thermrs-rig/1"
name = "{name}"

[robot]
model = "{model}"
joint_names = [{names}]
joint_states_topic = "/joint_states"
dh = [
{rows}
]

[laser]
origin_mm = {fmt(laser_origin_mm)}
direction = {fmt(laser_direction)}

{chr(10).join(cameras)}
{chr(10).join(poses)}
[thermal]
topic = "/ir/image"
size_px = [160, 120]
scale = 1.0
offset_c = 0.0

[[thermal.roi]]
name = "{rois[0]}"
rect_px = [10, 10, 60, 40]

[[thermal.roi]]
name = "{rois[1]}"
rect_px = [70, 20, 150, 50]

{ambient}[expansion]
alpha_per_k = 2.3e-05
reference_c = 20.0
length = [
{length}
]
"""
