"""Rig files (SPEC §3): load, validate and explain.

Parsing and validation happen in Rust (``thermrs-core``'s ``rig`` module); every problem is a
:class:`~thermrs.errors.RigError` whose one-line message names the file, the line where known,
and the key, e.g.::

    rig my-rig.toml line 48: camera[1]: unknown field `tpoic`, expected one of `name`, ...

Example
-------
>>> import thermrs
>>> rig = thermrs.load_rig(thermrs.default_rig_path())
>>> [c.name for c in rig.cameras]
['A', 'B']
>>> round(rig.explain()["poses"]["A"]["flange_mm"][0], 2)
1087.87
"""

from __future__ import annotations

import copy
import json
import os
from collections.abc import Mapping
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

import thermrs._native as _native
from thermrs.errors import InputError, RigError

__all__ = [
    "Camera",
    "DhRow",
    "LengthMap",
    "Pose",
    "Rig",
    "Roi",
    "as_rig",
    "default_rig_path",
    "geometry_variants",
    "load_rig",
]


def default_rig_path() -> Path:
    """Path of the embedded rig of the paper's set-up (KUKA KR 15/2, two lensless CCDs).

    Returns
    -------
    Path
        The rig file inside the installed package (``thermrs/data/kr15-paper.toml``).

    Examples
    --------
    >>> import thermrs
    >>> thermrs.default_rig_path().name
    'kr15-paper.toml'
    """
    return Path(str(resources.files("thermrs") / "data" / "kr15-paper.toml"))


@dataclass(frozen=True)
class DhRow:
    """One standard DH row; θ = sign·q + theta_offset."""

    a_mm: float
    alpha_deg: float
    d_mm: float
    theta_offset_deg: float
    sign: int


@dataclass(frozen=True)
class Camera:
    """A lensless CCD camera: its chip in the base frame and its pixel grid."""

    name: str
    topic: str
    pose: str
    centre_mm: tuple[float, float, float]
    x_axis: tuple[float, float, float]
    y_axis: tuple[float, float, float]
    pixel_pitch_um: tuple[float, float]
    size_px: tuple[int, int]

    def px_to_um(
        self, x_px: npt.ArrayLike, y_px: npt.ArrayLike
    ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
        """Chip micrometres (u, v) about the chip centre (SPEC §4)."""
        x = np.asarray(x_px, dtype=np.float64)
        y = np.asarray(y_px, dtype=np.float64)
        u = (x - (self.size_px[0] - 1) / 2) * self.pixel_pitch_um[0]
        v = (y - (self.size_px[1] - 1) / 2) * self.pixel_pitch_um[1]
        return u, v


@dataclass(frozen=True)
class Pose:
    """A taught pose: six joint angles in degrees as the controller reports them."""

    name: str
    joints_deg: tuple[float, float, float, float, float, float]

    @property
    def joints_rad(self) -> npt.NDArray[np.float64]:
        """The joint angles in radians (as JointState reports them)."""
        return np.radians(np.asarray(self.joints_deg, dtype=np.float64))


@dataclass(frozen=True)
class Roi:
    """A thermal region of interest: columns x0..x1−1, rows y0..y1−1."""

    name: str
    rect_px: tuple[int, int, int, int]


@dataclass(frozen=True)
class LengthMap:
    """A DH length (``a<i>`` / ``d<i>``) that expands with a temperature (ROI or ``ambient``)."""

    name: str
    temperature: str


class Rig:
    """A validated rig.

    Build it with :func:`load_rig` or :meth:`Rig.from_toml`; it cannot hold an invalid rig.
    """

    def __init__(self, native: _native.Rig, source: str) -> None:
        self._native = native
        self.source = source
        self._data: dict[str, Any] = json.loads(native.to_json())
        d = self._data
        robot = d["robot"]
        self.name: str | None = d.get("name")
        self.model: str = robot["model"]
        self.joint_names: list[str] = list(robot["joint_names"])
        self.joint_states_topic: str = robot["joint_states_topic"]
        self.dh: list[DhRow] = [DhRow(**row) for row in robot["dh"]]
        rates = robot.get("max_rate_deg_s")
        #: The joints' rated maximum rates (°/s), when the rig gives them.
        self.max_rate_deg_s: tuple[float, ...] | None = tuple(rates) if rates else None
        self.laser_origin_mm: tuple[float, ...] = tuple(d["laser"]["origin_mm"])
        self.laser_direction: tuple[float, ...] = tuple(d["laser"]["direction"])
        self.cameras: list[Camera] = [
            Camera(
                name=c["name"],
                topic=c["topic"],
                pose=c["pose"],
                centre_mm=tuple(c["centre_mm"]),
                x_axis=tuple(c["x_axis"]),
                y_axis=tuple(c["y_axis"]),
                pixel_pitch_um=tuple(c["pixel_pitch_um"]),
                size_px=tuple(c["size_px"]),
            )
            for c in d["camera"]
        ]
        self.poses: dict[str, Pose] = {
            p["name"]: Pose(p["name"], tuple(p["joints_deg"])) for p in d["pose"]
        }
        thermal = d.get("thermal")
        self.thermal_topic: str | None = thermal["topic"] if thermal else None
        self.thermal_size_px: tuple[int, int] | None = (
            tuple(thermal["size_px"]) if thermal else None
        )
        self.thermal_scale: float | None = thermal["scale"] if thermal else None
        self.thermal_offset_c: float | None = thermal["offset_c"] if thermal else None
        self.rois: list[Roi] = [
            Roi(r["name"], tuple(r["rect_px"])) for r in (thermal["roi"] if thermal else [])
        ]
        ambient = d.get("ambient")
        self.ambient_topic: str | None = ambient["topic"] if ambient else None
        exp = d["expansion"]
        self.alpha_per_k: float = exp["alpha_per_k"]
        self.reference_c: float = exp["reference_c"]
        self.lengths: list[LengthMap] = [LengthMap(**m) for m in exp["length"]]
        #: ``[tolerances]``: standard uncertainties (1 σ) of the rig and its instruments
        #: (SPEC §3), defaults filled in (``docs/tolerances.md``: the published metrology
        #: each default comes from).
        self.tolerances: dict[str, float] = {
            k: float(v) for k, v in json.loads(native.tolerances_json()).items()
        }
        #: Whether the file states its ``[tolerances]``; False: the defaults are in force,
        #: and a diagnosis says so.
        self.tolerances_stated: bool = native.tolerances_stated()

    # --- construction -----------------------------------------------------------------------
    @classmethod
    def from_path(cls, path: str | Path) -> Rig:
        """Read and validate a rig file.

        Raises
        ------
        RigError
            The file does not parse or validate; the message names the key.
        InputError
            The file cannot be read.
        """
        return cls(_native.Rig.from_path(str(path)), str(path))

    @classmethod
    def from_toml(cls, text: str, *, source_name: str = "<string>") -> Rig:
        """Parse and validate rig TOML text."""
        return cls(_native.Rig.from_toml(text, source_name), source_name)

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], *, source_name: str = "<dict>") -> Rig:
        """A rig from plain data (the keys of :meth:`to_dict`), validated as a file is."""
        return cls(_native.Rig.from_json(json.dumps(data), source_name), source_name)

    def __reduce__(self) -> tuple[Any, ...]:
        """Pickled as its validated JSON and source (for a campaign's Dask workers), and
        validated again when unpickled."""
        return (_from_json, (self._native.to_json(), self.source))

    # --- queries ----------------------------------------------------------------------------
    def camera(self, name: str) -> Camera:
        """The camera called ``name``."""
        for c in self.cameras:
            if c.name == name:
                return c
        known = ", ".join(c.name for c in self.cameras)
        raise RigError(f"rig {self.source}: no camera {name!r} (cameras: {known})")

    def camera_pose(self, camera: str) -> Pose:
        """The pose at which the laser hits ``camera``."""
        return self.poses[self.camera(camera).pose]

    @property
    def mapped_temperatures(self) -> list[str]:
        """Temperature names (ROIs or ``ambient``) the nominal model expands lengths with."""
        return self._native.mapped_temperatures()

    def to_dict(self) -> dict[str, Any]:
        """The rig as plain data (the file's keys)."""
        return json.loads(self._native.to_json())  # type: ignore[no-any-return]

    def explain(self) -> dict[str, Any]:
        """Every pose at nominal lengths: flange position, spot and incidence per camera.

        Returns the SPEC §7 ``thermrs rig --json`` shape, ``{"poses": {pose: {"flange_mm",
        "spot_px", "incidence_deg", ...}}}``, extended with ``distance_mm`` per camera,
        ``elevation_deg``/``azimuth_deg`` per pose and a ``problems`` list. A camera whose chip
        the ray misses has ``spot_px`` null.
        """
        return json.loads(self._native.explain_json())  # type: ignore[no-any-return]

    def check(self) -> dict[str, Any]:
        """:meth:`explain`, raising :class:`RigError` if the laser misses a pose's own camera."""
        view = self.explain()
        if view["problems"]:
            raise RigError(f"rig {self.source}: {view['problems'][0]}")
        return view

    def __repr__(self) -> str:
        cams = ", ".join(c.name for c in self.cameras)
        return f"Rig({self.source!r}, robot={self.model!r}, cameras=[{cams}])"


def _from_json(text: str, source: str) -> Rig:
    """A rig pickled by :meth:`Rig.__reduce__`."""
    return Rig(_native.Rig.from_json(text, source), source)


def load_rig(path: str | os.PathLike[str] | None = None) -> Rig:
    """Load and validate a rig file.

    Parameters
    ----------
    path
        The rig file (SPEC §3, ``format = "thermrs-rig/1"``); default: the embedded rig of the
        paper's set-up (:func:`default_rig_path`).

    Returns
    -------
    Rig
        The validated rig.

    Raises
    ------
    RigError
        The file does not parse or validate; the one-line message names the line and key.
    InputError
        The file does not exist, is a directory or cannot be read.

    Examples
    --------
    >>> import thermrs
    >>> rig = thermrs.load_rig()
    >>> rig.model, [c.name for c in rig.cameras]
    ('KUKA KR 15/2', ['A', 'B'])
    """
    p = default_rig_path() if path is None else Path(path)
    if p.is_dir():
        raise InputError(f"rig {p}: is a directory, expected a rig file (.toml)")
    if not p.exists():
        raise InputError(f"rig {p}: no such file")
    try:
        with p.open("rb") as f:
            head = f.read(4096)
    except OSError as e:
        raise InputError(f"rig {p}: cannot read it ({e.strerror or e})") from None
    binary = b"\0" in head or not _utf8_prefix(head)
    if binary:
        raise InputError(f"rig {p}: not a text file; a rig file is TOML (SPEC §3)")
    return Rig.from_path(p)


def _utf8_prefix(head: bytes) -> bool:
    """Whether ``head`` is UTF-8 text, but for a character cut at its end."""
    try:
        head.decode("utf-8")
    except UnicodeDecodeError as e:
        return e.start >= len(head) - 3 and e.reason == "unexpected end of data"
    return True


def as_rig(rig: Rig | str | os.PathLike[str], *, what: str = "rig") -> Rig:
    """A :class:`Rig` as given, or the rig file at a path (``str`` or :class:`~pathlib.Path`)
    loaded with :func:`load_rig`.

    Parameters
    ----------
    rig
        A rig, or the path of a rig file.
    what
        How messages name the argument.

    Returns
    -------
    Rig
        The rig.

    Raises
    ------
    TypeError
        ``rig`` is neither a :class:`Rig` nor a path.
    RigError, InputError
        As :func:`load_rig`.

    Examples
    --------
    >>> import thermrs
    >>> from thermrs.rig import as_rig
    >>> as_rig(thermrs.default_rig_path()).model
    'KUKA KR 15/2'
    """
    if isinstance(rig, Rig):
        return rig
    if isinstance(rig, (str, os.PathLike)):
        return load_rig(rig)
    raise TypeError(
        f"{what} must be a thermrs.Rig or the path of a rig file (str or Path), "
        f"not {type(rig).__name__}"
    )


def radians_hint(rig: Rig) -> str:
    """Why no visit may have matched a rig's poses: poses given in radians where degrees are
    expected.

    Returns
    -------
    str
        A parenthesised hint to append to a message, or ``""`` where some pose lies outside
        ±2π.
    """
    import math

    small = [p.name for p in rig.poses.values() if all(abs(q) <= 2 * math.pi for q in p.joints_deg)]
    if small and len(small) == len(rig.poses):
        return (
            f" (rig {Path(rig.source).name}: every pose's joints_deg lies within ±2π, like "
            "radians; poses are in degrees, as the controller reports them)"
        )
    return ""


# --- a rig moved by its tolerances ---------------------------------------------------------

FloatArray = npt.NDArray[np.float64]


def _rotation(axis: FloatArray, angle_rad: float) -> FloatArray:
    a = axis / np.linalg.norm(axis)
    k = np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])
    out: FloatArray = np.eye(3) + np.sin(angle_rad) * k + (1.0 - np.cos(angle_rad)) * (k @ k)
    return out


def _unit_perpendiculars(d: FloatArray) -> tuple[FloatArray, FloatArray]:
    d = d / np.linalg.norm(d)
    helper = np.array([1.0, 0.0, 0.0]) if abs(d[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = np.cross(d, helper)
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(d, e1)


def geometry_variants(rig: Rig) -> list[tuple[str, dict[str, object]]]:
    """The rig with one geometric quantity at a time moved by its standard uncertainty (the
    rig's ``[tolerances]``): every DH length, twist and joint zero, each chip's centre and
    orientation, the laser's origin and direction — what the diagnoser's null world draws and
    a compensation law's intervals count.

    Parameters
    ----------
    rig
        The rig and its tolerances.

    Returns
    -------
    list of (str, dict)
        Per quantity with a tolerance above zero: its name and the moved rig as plain data
        (:meth:`Rig.to_dict`'s keys; :meth:`Rig.from_dict` validates it).

    Raises
    ------
    KeyError
        Never for a validated rig (its data carry every key read).

    Examples
    --------
    >>> import thermrs
    >>> names = [n for n, _ in thermrs.rig.geometry_variants(thermrs.load_rig())]
    >>> names[0], len(names) > 20
    ('dh[0].a_mm', True)
    """
    tol = rig.tolerances
    base = rig.to_dict()
    out: list[tuple[str, dict[str, object]]] = []

    def variant(name: str, edit: object) -> None:
        d = copy.deepcopy(base)
        edit(d)  # type: ignore[operator]
        out.append((name, d))

    for i in range(len(base["robot"]["dh"])):
        for key, sd in (
            ("a_mm", tol["length_mm"]),
            ("d_mm", tol["length_mm"]),
            ("alpha_deg", tol["angle_deg"]),
            ("theta_offset_deg", tol["angle_deg"]),
        ):
            if sd > 0:
                variant(
                    f"dh[{i}].{key}",
                    lambda d, i=i, key=key, sd=sd: d["robot"]["dh"][i].__setitem__(
                        key, d["robot"]["dh"][i][key] + sd
                    ),
                )
    for j, cam in enumerate(base["camera"]):
        if tol["chip_mm"] > 0:
            for k in range(3):

                def shift(d: dict, j: int = j, k: int = k) -> None:  # type: ignore[type-arg]
                    d["camera"][j]["centre_mm"][k] += tol["chip_mm"]

                variant(f"camera[{cam['name']}].centre_mm[{k}]", shift)
        if tol["chip_deg"] > 0:
            x = np.asarray(cam["x_axis"], dtype=np.float64)
            y = np.asarray(cam["y_axis"], dtype=np.float64)
            for name, axis in (("x", x), ("y", y), ("normal", np.cross(x, y))):
                rot = _rotation(axis, np.deg2rad(tol["chip_deg"]))

                def turn(d: dict, j: int = j, rot: FloatArray = rot) -> None:  # type: ignore[type-arg]
                    for key in ("x_axis", "y_axis"):
                        d["camera"][j][key] = (rot @ np.asarray(d["camera"][j][key])).tolist()

                variant(f"camera[{cam['name']}].turned about {name}", turn)
    if tol["laser_mm"] > 0:
        for k in range(3):

            def move(d: dict, k: int = k) -> None:  # type: ignore[type-arg]
                d["laser"]["origin_mm"][k] += tol["laser_mm"]

            variant(f"laser.origin_mm[{k}]", move)
    if tol["laser_deg"] > 0:
        direction = np.asarray(base["laser"]["direction"], dtype=np.float64)
        for k, axis in enumerate(_unit_perpendiculars(direction)):
            rot = _rotation(axis, np.deg2rad(tol["laser_deg"]))

            def tilt(d: dict, rot: FloatArray = rot) -> None:  # type: ignore[type-arg]
                d["laser"]["direction"] = (rot @ np.asarray(d["laser"]["direction"])).tolist()

            variant(f"laser.direction tilted ({k + 1})", tilt)
    return out
