"""The bench world's geometry: a rig file read with :mod:`tomllib` and the laser spot computed
from the DH convention and ray–plane geometry directly in numpy (SPEC §3–4).

Nothing here comes from :mod:`thermrs.model`, :mod:`thermrs.rig` or the Rust core: this is a
second implementation, used only to make bench cases, so that the diagnoser is never scored on
runs made by its own forward model. Agreement of the two on nominal spots is a test of both
(``tests/bench/test_world.py``).

Standard (distal) DH, base to flange: Tᵢ = Rz(θᵢ)·Tz(dᵢ)·Tx(aᵢ)·Rx(αᵢ), θᵢ = signᵢ·qᵢ +
theta_offsetᵢ. The laser ray (origin, direction in the flange frame) is mapped to the base
frame; the spot is where it meets the chip plane (through the chip centre, normal
x_axis × y_axis); u, v (µm) are its coordinates along the chip axes from the centre.
"""

from __future__ import annotations

import re
import tomllib
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]

__all__ = ["Chip", "WorldRig", "laser_spots", "perturbed", "read_rig"]


@dataclass(frozen=True)
class Chip:
    """A CCD chip: its pose in the base frame (mm, unit axes) and the pose that aims at it."""

    name: str
    pose: str
    centre_mm: FloatArray
    x_axis: FloatArray
    y_axis: FloatArray


@dataclass(frozen=True)
class WorldRig:
    """What the bench world needs of a rig file: six DH rows, the laser, the chips, the taught
    poses, the ROI names and the expansion map (length name → temperature name)."""

    a_mm: FloatArray
    alpha_deg: FloatArray
    d_mm: FloatArray
    theta_offset_deg: FloatArray
    sign: FloatArray
    joint_names: tuple[str, ...]
    laser_origin_mm: FloatArray
    laser_direction: FloatArray
    chips: tuple[Chip, ...]
    poses_deg: dict[str, FloatArray]
    rois: tuple[str, ...]
    alpha_per_k: float
    reference_c: float
    expansion: dict[str, str]
    #: The rig file it was read from.
    source: str = ""

    def chip(self, name: str) -> Chip:
        """The chip called ``name``."""
        for c in self.chips:
            if c.name == name:
                return c
        raise KeyError(name)

    def taught_rad(self, camera: str) -> FloatArray:
        """The taught joint angles (rad, as the controller reports them) of ``camera``'s pose."""
        return np.deg2rad(self.poses_deg[self.chip(camera).pose])

    def unlisted_lengths(self) -> list[str]:
        """Non-zero DH lengths (``a<i>``/``d<i>``) the expansion map does not list."""
        out = []
        for i in range(6):
            for kind, val in (("a", self.a_mm[i]), ("d", self.d_mm[i])):
                name = f"{kind}{i + 1}"
                if abs(val) > 1e-9 and name not in self.expansion:
                    out.append(name)
        return out


def _vec(x: Any) -> FloatArray:
    return np.asarray(x, dtype=np.float64)


def read_rig(path: str | Path) -> WorldRig:
    """Parse a ``thermrs-rig/1`` file with :mod:`tomllib` (the keys SPEC §3 defines).

    Parameters
    ----------
    path
        The rig file.

    Returns
    -------
    WorldRig
    """
    with open(path, "rb") as f:
        doc = tomllib.load(f)
    dh = doc["robot"]["dh"]
    if len(dh) != 6:
        raise ValueError(f"rig {path}: robot.dh has {len(dh)} rows, expected 6")
    chips = tuple(
        Chip(
            name=str(c["name"]),
            pose=str(c["pose"]),
            centre_mm=_vec(c["centre_mm"]),
            x_axis=_vec(c["x_axis"]),
            y_axis=_vec(c["y_axis"]),
        )
        for c in doc["camera"]
    )
    exp = doc["expansion"]
    lengths = exp.get("length", [])
    return WorldRig(
        a_mm=_vec([r["a_mm"] for r in dh]),
        alpha_deg=_vec([r["alpha_deg"] for r in dh]),
        d_mm=_vec([r["d_mm"] for r in dh]),
        theta_offset_deg=_vec([r["theta_offset_deg"] for r in dh]),
        sign=_vec([r["sign"] for r in dh]),
        joint_names=tuple(doc["robot"]["joint_names"]),
        laser_origin_mm=_vec(doc["laser"]["origin_mm"]),
        laser_direction=_vec(doc["laser"]["direction"]),
        chips=chips,
        poses_deg={str(p["name"]): _vec(p["joints_deg"]) for p in doc["pose"]},
        rois=tuple(str(r["name"]) for r in doc.get("thermal", {}).get("roi", [])),
        alpha_per_k=float(exp["alpha_per_k"]),
        reference_c=float(exp["reference_c"]),
        expansion={str(m["name"]): str(m["temperature"]) for m in lengths},
        source=str(path),
    )


_LENGTH = re.compile(r"^([ad])([1-6])$")


def length_index(name: str) -> tuple[str, int]:
    """(``"a"`` or ``"d"``, 0-based row) of a DH length name."""
    m = _LENGTH.match(name)
    if m is None:
        raise ValueError(f"not a DH length: {name!r}")
    return m.group(1), int(m.group(2)) - 1


def _rotation(axis: FloatArray, angle: float) -> FloatArray:
    """Rodrigues' rotation matrix about a unit ``axis``."""
    k = axis / np.linalg.norm(axis)
    kx = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    out = np.eye(3) + np.sin(angle) * kx + (1.0 - np.cos(angle)) * (kx @ kx)
    return np.asarray(out, dtype=np.float64)


def tilted(direction: FloatArray, tilt_deg: float, azimuth_deg: float) -> FloatArray:
    """``direction`` turned by ``tilt_deg`` about an axis perpendicular to it; the axis is
    direction × flange z turned by ``azimuth_deg`` about the direction."""
    d = direction / np.linalg.norm(direction)
    axis = np.cross(d, [0.0, 0.0, 1.0])
    if np.linalg.norm(axis) < 1e-9:
        axis = np.array([1.0, 0.0, 0.0])
    axis = _rotation(d, np.deg2rad(azimuth_deg)) @ (axis / np.linalg.norm(axis))
    out = _rotation(axis, np.deg2rad(tilt_deg)) @ d
    return np.asarray(out / np.linalg.norm(out), dtype=np.float64)


def flange(
    rig: WorldRig, q_rad: FloatArray, a_mm: FloatArray, d_mm: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """Flange rotations (N, 3, 3) and positions (N, 3) for joint angles ``q_rad`` (N, 6) and
    per-sample lengths ``a_mm``, ``d_mm`` (N, 6)."""
    n = q_rad.shape[0]
    theta = rig.sign[None, :] * q_rad + np.deg2rad(rig.theta_offset_deg)[None, :]
    al = np.deg2rad(rig.alpha_deg)
    r = np.broadcast_to(np.eye(3), (n, 3, 3)).copy()
    p = np.zeros((n, 3))
    for i in range(6):
        ct, st = np.cos(theta[:, i]), np.sin(theta[:, i])
        ca, sa = np.cos(al[i]), np.sin(al[i])
        ri = np.empty((n, 3, 3))
        ri[:, 0, 0], ri[:, 0, 1], ri[:, 0, 2] = ct, -st * ca, st * sa
        ri[:, 1, 0], ri[:, 1, 1], ri[:, 1, 2] = st, ct * ca, -ct * sa
        ri[:, 2, 0], ri[:, 2, 1], ri[:, 2, 2] = 0.0, sa, ca
        ti = np.stack([a_mm[:, i] * ct, a_mm[:, i] * st, d_mm[:, i]], axis=1)
        p = p + np.einsum("nij,nj->ni", r, ti)
        r = np.einsum("nij,njk->nik", r, ri)
    return r, p


def laser_spots(
    rig: WorldRig,
    camera: str,
    q_rad: FloatArray,
    a_mm: FloatArray | None = None,
    d_mm: FloatArray | None = None,
    laser_direction: FloatArray | None = None,
) -> FloatArray:
    """(N, 2) spot coordinates u, v (µm from the chip centre along its axes) on ``camera``.

    Parameters
    ----------
    rig
        The geometry.
    camera
        The chip's name.
    q_rad
        Joint angles (N, 6) as the controller reports them (rad).
    a_mm, d_mm
        Per-sample DH lengths (N, 6); default the rig's.
    laser_direction
        The laser direction in the flange frame; default the rig's.
    """
    q = np.atleast_2d(q_rad)
    n = q.shape[0]
    a = np.broadcast_to(rig.a_mm, (n, 6)) if a_mm is None else a_mm
    d = np.broadcast_to(rig.d_mm, (n, 6)) if d_mm is None else d_mm
    r, p = flange(rig, q, a, d)
    lo = rig.laser_origin_mm
    ld = rig.laser_direction if laser_direction is None else laser_direction
    ld = ld / np.linalg.norm(ld)
    origin = p + r @ lo
    ray = r @ ld
    chip = rig.chip(camera)
    normal = np.cross(chip.x_axis, chip.y_axis)
    lam = ((chip.centre_mm[None, :] - origin) @ normal) / (ray @ normal)
    hit = origin + lam[:, None] * ray - chip.centre_mm[None, :]
    return np.stack([hit @ chip.x_axis, hit @ chip.y_axis], axis=1) * 1000.0


def perturbed(
    rig: WorldRig,
    rng: np.random.Generator,
    *,
    length_mm: float,
    angle_deg: float,
    chip_mm: float,
    chip_deg: float,
    laser_mm: float,
    laser_deg: float,
) -> WorldRig:
    """The true rig: the nominal one with its geometry misspecified, each quantity drawn
    from a normal distribution of the given standard deviation (a rig's stated tolerances,
    scaled): every non-zero DH length, every twist and joint zero, each chip's centre along
    each axis and its orientation (a rotation whose three components are each drawn), the
    laser's origin along each axis and its direction (tilted about two axes across it)."""
    nd = rig.a_mm.size

    def jitter(sd: float) -> FloatArray:
        return rng.normal(0.0, sd, nd) if sd > 0 else np.zeros(nd)

    chips = []
    for c in rig.chips:
        rotvec = rng.normal(0.0, np.deg2rad(chip_deg), 3) if chip_deg > 0 else np.zeros(3)
        angle = float(np.linalg.norm(rotvec))
        rot = _rotation(rotvec, angle) if angle > 0 else np.eye(3)
        shift = rng.normal(0.0, chip_mm, 3) if chip_mm > 0 else np.zeros(3)
        chips.append(
            replace(
                c,
                centre_mm=c.centre_mm + shift,
                x_axis=rot @ c.x_axis,
                y_axis=rot @ c.y_axis,
            )
        )
    direction = rig.laser_direction / np.linalg.norm(rig.laser_direction)
    helper = np.array([1.0, 0.0, 0.0]) if abs(direction[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = np.cross(direction, helper)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(direction, e1)
    tilt = rng.normal(0.0, np.deg2rad(laser_deg), 2) if laser_deg > 0 else np.zeros(2)
    tilt_vec = tilt[0] * e1 + tilt[1] * e2
    tilt_angle = float(np.linalg.norm(tilt_vec))
    if tilt_angle > 0:
        direction = _rotation(tilt_vec, tilt_angle) @ direction
    origin = rng.normal(0.0, laser_mm, 3) if laser_mm > 0 else np.zeros(3)
    return replace(
        rig,
        a_mm=rig.a_mm + np.where(rig.a_mm != 0, jitter(length_mm), 0.0),
        d_mm=rig.d_mm + np.where(rig.d_mm != 0, jitter(length_mm), 0.0),
        alpha_deg=rig.alpha_deg + jitter(angle_deg),
        theta_offset_deg=rig.theta_offset_deg + jitter(angle_deg),
        laser_origin_mm=rig.laser_origin_mm + origin,
        laser_direction=direction * float(np.linalg.norm(rig.laser_direction)),
        chips=tuple(chips),
    )
