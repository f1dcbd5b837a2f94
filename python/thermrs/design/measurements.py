"""Candidate additional measurements: new poses with a new chip, and run protocols.

A candidate is what the user would add to the rig and record: at most one new pose with a new
CCD chip (placed where the laser lands at that pose, at a chosen distance along the beam, its
chip plane facing the beam), and the runs to record (a *protocol*: speeds, durations, a cold
or warm start, idle time for a cool-down). Its cost is the recording hours, idle time included.

New poses turn one joint (or two) of a taught pose by a fixed step, kept within joint limits:
the wrist (joints 4–6), which turns the beam away from the directions of the main axes, and the
arm (joints 2 and 3). The rig file format has no joint limits, so the limits are given by the
caller or default to :data:`DEFAULT_LIMITS_DEG` (the KUKA KR 15/2's axis ranges, stated in
``design.json``). Collisions with the robot's own links, the table or the other chips are not
checked: a chip must lie on the side of the base plane where the rig's own chips lie (above it,
z ≥ 0, unless they all lie below it, as on a robot mounted overhead) and at least
:data:`MIN_RADIUS_MM` from the base axis; the user checks the rest before mounting it.
"""

from __future__ import annotations

import string
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from thermrs.model import ForwardModel
from thermrs.rig import Rig

__all__ = [
    "DEFAULT_LIMITS_DEG",
    "Candidate",
    "Protocol",
    "RunPlan",
    "candidates",
    "chip_at",
    "protocols",
]

FloatArray = npt.NDArray[np.float64]

#: Joint ranges (degrees, as the controller reports them) when none are given: the KUKA
#: KR 15/2's axis ranges (A1 ±185°, A2 −155…+35° about KUKA's zero, which the paper rig's
#: convention moves, so taken as ±155°, A3 −130…+154°, A4 ±350°, A5 ±130°, A6 ±350°).
DEFAULT_LIMITS_DEG: tuple[tuple[float, float], ...] = (
    (-185.0, 185.0),
    (-155.0, 155.0),
    (-130.0, 154.0),
    (-350.0, 350.0),
    (-130.0, 130.0),
    (-350.0, 350.0),
)
#: Joint steps (degrees) applied to a taught pose: (joint index 0-based, step), one or two.
POSE_STEPS: tuple[tuple[tuple[int, float], ...], ...] = (
    ((3, 30.0),),
    ((3, -30.0),),
    ((3, 60.0),),
    ((3, -60.0),),
    ((3, 90.0),),
    ((3, -90.0),),
    ((4, 30.0),),
    ((4, -30.0),),
    ((5, 90.0),),
    ((1, 15.0),),
    ((2, -15.0),),
    ((3, 90.0), (4, 30.0)),
    ((3, -90.0), (4, -30.0)),
    ((2, -30.0), (3, 90.0)),
    ((2, -30.0), (3, -90.0)),
    ((1, 15.0), (3, 90.0)),
    ((1, 15.0), (3, -90.0)),
    ((2, -30.0),),
    ((2, 30.0),),
)
#: Distances (mm) from the laser's exit to the new chip's centre.
DISTANCES_MM: tuple[float, ...] = (150.0, 250.0, 400.0, 600.0)
#: Least distance (mm) of a new chip's centre from the robot's base axis.
MIN_RADIUS_MM = 300.0


@dataclass(frozen=True)
class RunPlan:
    """One run to record (a SPEC scenario ``[[run]]``) and what ``thermrs diagnose`` should do
    with it."""

    name: str
    speed_pct: float
    duration_min: float
    start: str  # "ambient" or "continue"
    idle_before_min: float
    role: str  # "train" or "holdout"

    def to_scenario(self, cycle_s: float) -> dict[str, Any]:
        """The scenario's ``[[run]]`` table."""
        d: dict[str, Any] = {
            "name": self.name,
            "speed_pct": self.speed_pct,
            "duration_min": self.duration_min,
            "cycle_s": cycle_s,
            "start": self.start,
        }
        if self.idle_before_min > 0:
            d["idle_before_min"] = self.idle_before_min
        return d


@dataclass(frozen=True)
class Protocol:
    """A sequence of runs (speeds, durations, starts, idle time), and what the room must do
    meanwhile: ``ambient`` are keys of the scenario's ``[ambient]`` table (``swing_c``, the
    amplitude of the room's daily swing; ``drift_c_per_h``), empty for a room held steady;
    ``room`` says it in words."""

    label: str
    runs: tuple[RunPlan, ...]
    ambient: tuple[tuple[str, float], ...] = ()
    room: str | None = None

    @property
    def hours(self) -> float:
        """Robot time: every run and every idle period, hours."""
        return sum(r.duration_min + r.idle_before_min for r in self.runs) / 60.0


@dataclass(frozen=True)
class Candidate:
    """One candidate additional measurement."""

    label: str
    kind: str  # "pose" (a new pose and chip, recorded with the protocol) or "protocol"
    protocol: Protocol
    pose: dict[str, Any] | None = None  # {"name", "joints_deg"}
    camera: dict[str, Any] | None = None  # a rig [[camera]] table
    detail: dict[str, Any] = field(default_factory=dict)

    @property
    def hours(self) -> float:
        """Recording hours."""
        return self.protocol.hours

    def to_json(self) -> dict[str, Any]:
        """The candidate as ``design.json`` lists it."""
        return {
            "label": self.label,
            "kind": self.kind,
            "hours": self.hours,
            "pose": self.pose,
            "camera": self.camera,
            "room": self.protocol.room,
            "ambient": dict(self.protocol.ambient),
            "runs": [
                {
                    "name": r.name,
                    "speed_pct": r.speed_pct,
                    "duration_min": r.duration_min,
                    "start": r.start,
                    "idle_before_min": r.idle_before_min,
                    "role": r.role,
                }
                for r in self.protocol.runs
            ],
            **self.detail,
        }


#: The amplitude (K) of the room's daily swing a ``room-swing`` protocol asks for.
ROOM_SWING_C = 2.0


def protocols(*, prefix: str = "design", room_swing: bool = True) -> list[Protocol]:
    """The run protocols searched: each has a training run and a held-out run (the held-out
    run must carry whatever the new measurement adds, so that the diagnoser scores on it).

    - ``hot-cool``: a cold start at 75 % (the links heat), then 10 % (they cool): the drivers
      rise and fall within the design;
    - ``fast-idle-slow``: 100 % from cold, an idle cool-down of 2 h, then 30 %;
    - ``hot-rest-slow``: 75 % from cold for 8 h, the robot at rest for a stated cool-down
      (4 or 8 h), then 10 % for 4 h: the links' cooling and the warm restart held out;
    - ``two-speeds-warm``: 50 %, then 30 % straight after it (a warm start);
    - ``room-swing`` (with ``room_swing``, for rigs with an ambient thermometer): 30 % for a
      whole day while the room swings by ±:data:`ROOM_SWING_C` K (its climate control off, or
      its set point moved): the room's temperature then moves apart from the links', which
      separates what the room drives (a fixture, a length that follows the room) from what
      the links drive;
    each but the last in a short and a long version.
    """
    out = []
    for hours in (4.0, 6.0, 8.0, 10.0, 12.0):
        m = hours * 60.0
        out.append(
            Protocol(
                f"hot-cool {hours:g}+{hours:g} h",
                (
                    RunPlan(f"{prefix}-hot", 75.0, m, "ambient", 0.0, "train"),
                    RunPlan(f"{prefix}-cool", 10.0, m, "continue", 0.0, "holdout"),
                ),
            )
        )
    for hours in (5.0, 8.0):
        m = hours * 60.0
        out.append(
            Protocol(
                f"fast-idle-slow {hours:g}+2+{hours:g} h",
                (
                    RunPlan(f"{prefix}-fast", 100.0, m, "ambient", 0.0, "train"),
                    RunPlan(f"{prefix}-slow", 30.0, m, "continue", 120.0, "holdout"),
                ),
            )
        )
    for rest in (4.0, 8.0):
        out.append(
            Protocol(
                f"hot-rest-slow 8+{rest:g}+4 h (a {rest:g}-h cool-down)",
                (
                    RunPlan(f"{prefix}-heat", 75.0, 480.0, "ambient", 0.0, "train"),
                    RunPlan(f"{prefix}-after", 10.0, 240.0, "continue", rest * 60.0, "holdout"),
                ),
            )
        )
    out.append(
        Protocol(
            "two-speeds-warm 8+8 h",
            (
                RunPlan(f"{prefix}-mid", 50.0, 480.0, "ambient", 0.0, "train"),
                RunPlan(f"{prefix}-warm", 30.0, 480.0, "continue", 0.0, "holdout"),
            ),
        )
    )
    if room_swing:
        out.append(
            Protocol(
                f"room-swing 12+12 h (room ±{ROOM_SWING_C:g} K over the day)",
                (
                    RunPlan(f"{prefix}-day", 30.0, 720.0, "ambient", 0.0, "train"),
                    RunPlan(f"{prefix}-night", 30.0, 720.0, "continue", 0.0, "holdout"),
                ),
                ambient=(("swing_c", ROOM_SWING_C),),
                room=f"the room's temperature swings by ±{ROOM_SWING_C:g} K over the day "
                "(climate control off, or its set point moved)",
            )
        )
    return out


def _laser_ray(rig: Rig, joints_deg: FloatArray) -> tuple[FloatArray, FloatArray]:
    """The laser's origin (mm) and unit direction in the base frame at nominal lengths."""
    t = ForwardModel(rig).flange_transforms(np.radians(joints_deg))[0]
    o = t[:3, :3] @ np.asarray(rig.laser_origin_mm) + t[:3, 3]
    d = t[:3, :3] @ np.asarray(rig.laser_direction)
    return o, d / np.linalg.norm(d)


def chip_at(
    rig: Rig, joints_deg: FloatArray, distance_mm: float, like: str
) -> dict[str, Any] | None:
    """A chip (rig ``[[camera]]`` fields but name, topic and pose) centred where the laser
    meets it ``distance_mm`` from its exit at ``joints_deg``, its plane normal to the beam;
    pitch and size copied from camera ``like``. None where it would sit on the other side of
    the base plane than the rig's chips (below it, unless they all lie below it) or within
    :data:`MIN_RADIUS_MM` of the base axis."""
    o, d = _laser_ray(rig, joints_deg)
    c = o + distance_mm * d
    below = all(cam.centre_mm[2] < 0.0 for cam in rig.cameras)
    if (c[2] >= 0.0) == below or float(np.hypot(c[0], c[1])) < MIN_RADIUS_MM:
        return None
    ref = np.array([0.0, 0.0, 1.0]) if abs(d[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    x = np.cross(ref, d)
    x /= np.linalg.norm(x)
    y = np.cross(d, x)
    cam = rig.camera(like)
    return {
        "centre_mm": [float(v) for v in c],
        "x_axis": [float(v) for v in x],
        "y_axis": [float(v) for v in y],
        "pixel_pitch_um": list(cam.pixel_pitch_um),
        "size_px": list(cam.size_px),
    }


def _free_name(taken: set[str]) -> str:
    for ch in string.ascii_uppercase:
        if ch not in taken:
            return ch
    return f"N{len(taken)}"


def candidates(
    rig: Rig,
    *,
    limits_deg: tuple[tuple[float, float], ...] = DEFAULT_LIMITS_DEG,
    protocol: Protocol,
    distances_mm: tuple[float, ...] = DISTANCES_MM,
) -> list[Candidate]:
    """Every new pose (a taught pose with :data:`POSE_STEPS` applied, within ``limits_deg``)
    with a new chip at each of ``distances_mm``, recorded with ``protocol``."""
    cam_name = _free_name({c.name for c in rig.cameras} | set(rig.poses))
    out: list[Candidate] = []
    seen: set[tuple[float, ...]] = set()
    for cam in rig.cameras:
        base = np.asarray(rig.poses[cam.pose].joints_deg, dtype=np.float64)
        for steps in POSE_STEPS:
            q = base.copy()
            for j, step in steps:
                q[j] += step
            if any(not (lo <= v <= hi) for v, (lo, hi) in zip(q, limits_deg, strict=True)):
                continue
            key = tuple(np.round(q, 3))
            if key in seen:
                continue
            seen.add(key)
            what = ", ".join(f"joint {j + 1} {s:+g}°" for j, s in steps)
            for dist in distances_mm:
                chip = chip_at(rig, q, dist, cam.name)
                if chip is None:
                    continue
                camera = {
                    "name": cam_name,
                    "topic": f"/ccd_{cam_name.lower()}/image_raw",
                    "pose": cam_name,
                    **chip,
                }
                out.append(
                    Candidate(
                        label=f"new chip {cam_name} at pose {cam.pose} with {what}, "
                        f"{dist:g} mm from the laser; {protocol.label}",
                        kind="pose",
                        protocol=protocol,
                        pose={"name": cam_name, "joints_deg": [float(v) for v in q]},
                        camera=camera,
                        detail={
                            "from_pose": cam.pose,
                            # The camera seen at that pose: the new chip is visited when it is.
                            "from_camera": cam.name,
                            "joint_steps_deg": {f"joint {j + 1}": s for j, s in steps},
                            "distance_mm": dist,
                        },
                    )
                )
    return out
