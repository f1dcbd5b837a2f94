"""The thermal-expansion forward model (SPEC §4) on numpy arrays.

The physics lives in Rust (``thermrs-core``'s ``model`` module): a DH length L listed in the
rig's ``[expansion]`` expands to ``L·(1 + α·ΔT·(1 + κ·ΔT))`` with ΔT the mapped temperature
minus ``reference_c``; the flange pose is the DH product with the expanded lengths; the laser
ray meets the chip plane; the hit is expressed in pixels (SPEC §4 convention). Batches of
millions of samples run with the GIL released, spread over the cores; Ctrl-C interrupts them.

Example
-------
>>> import numpy as np, thermrs
>>> rig = thermrs.load_rig()
>>> model = thermrs.ForwardModel(rig, alpha_per_k=21.75e-6)
>>> t = np.linspace(23.0, 30.0, 5)
>>> spots = model.spots("A", rig.camera_pose("A").joints_rad,
...                     temperatures={"link2": t, "link3": t})
>>> bool(np.all(np.diff(spots.y_px) > 0))
True
"""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt
import polars as pl

import thermrs._native as _native
from thermrs.effects import (
    AlphaPerLink,
    Effect,
    JointOffset,
    LaserTilt,
    NonlinearAlpha,
    UnmodelledLength,
    effects_from,
    to_json,
)
from thermrs.errors import InputError
from thermrs.rig import Rig, as_rig

__all__ = ["ForwardModel", "Spots"]

Progress = Callable[[int, int], object]
FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True)
class Spots:
    """Where the laser meets one camera's chip plane, per sample.

    NaN where the ray does not meet the plane in front of the laser. Positions off the chip
    are kept (they are still positions on the plane); see :attr:`on_chip`.
    """

    camera: str
    x_px: FloatArray
    y_px: FloatArray
    distance_mm: FloatArray
    incidence_deg: FloatArray
    size_px: tuple[int, int]
    pixel_pitch_um: tuple[float, float]

    @property
    def on_chip(self) -> npt.NDArray[np.bool_]:
        """Whether each hit lies on the chip's light-sensitive area."""
        w, h = self.size_px
        return (
            (self.x_px >= -0.5)
            & (self.x_px <= w - 0.5)
            & (self.y_px >= -0.5)
            & (self.y_px <= h - 0.5)
        )

    @property
    def u_um(self) -> FloatArray:
        """Chip micrometres along the chip x axis, about the chip centre."""
        return (self.x_px - (self.size_px[0] - 1) / 2) * self.pixel_pitch_um[0]

    @property
    def v_um(self) -> FloatArray:
        """Chip micrometres along the chip y axis, about the chip centre."""
        return (self.y_px - (self.size_px[1] - 1) / 2) * self.pixel_pitch_um[1]

    def to_polars(self) -> pl.DataFrame:
        """The spots as a table (columns x_px, y_px, u_um, v_um, distance_mm, incidence_deg)."""
        return pl.DataFrame(
            {
                "x_px": self.x_px,
                "y_px": self.y_px,
                "u_um": self.u_um,
                "v_um": self.v_um,
                "distance_mm": self.distance_mm,
                "incidence_deg": self.incidence_deg,
            }
        )


class ForwardModel:
    """A rig's robot, laser and chips under one expansion law.

    Parameters
    ----------
    rig
        The validated rig, or the path of a rig file (``str`` or :class:`~pathlib.Path`).
    alpha_per_k
        α (1/K) for every mapped temperature; default the rig's ``expansion.alpha_per_k``.
    reference_c
        Temperature (°C) at which the rig's lengths hold; default ``expansion.reference_c``.
    effects
        SPEC §6 effects (:mod:`thermrs.effects` objects or their JSON dicts) the model carries:
        the geometric ones move the spot here; ``thermal_lag`` and the chip effects are applied
        by :class:`thermrs.signatures.VisitSet` and the simulator, which have the time axis.
    alpha_by_temperature
        One α per mapped temperature name, overriding ``alpha_per_k`` (SPEC §6
        ``alpha_per_link``; the same as ``effects=[AlphaPerLink(...)]``).
    kappa_per_k
        Quadratic strain term: strain = α·ΔT·(1 + κ·ΔT) (SPEC §6 ``nonlinear_alpha``).
    extra_lengths
        ``{length: temperature}``: DH lengths (``a<i>``/``d<i>``) the rig does not list that
        expand too (SPEC §6 ``unmodelled_length``).
    joint_offsets
        ``[(joint, temperature, µrad_per_k)]``: a joint (rig joint name or 1-based number)
        whose zero moves by that much per kelvin above ``reference_c`` (``joint_offset``).
    laser_tilt_deg
        The laser's true direction is the rig's turned by this angle (``laser_tilt``); a pair
        ``(tilt, azimuth)`` also turns the tilt axis about the ray (see the Rust
        ``model::LaserTilt``).

    The temperatures the model needs (:attr:`temperature_names`) are the rig's mapped ones
    followed by those the effects add.
    """

    def __init__(
        self,
        rig: Rig | str | os.PathLike[str],
        *,
        alpha_per_k: float | None = None,
        reference_c: float | None = None,
        effects: Sequence[Effect | Mapping[str, Any]] | None = None,
        alpha_by_temperature: Mapping[str, float] | None = None,
        kappa_per_k: float = 0.0,
        extra_lengths: Mapping[str, str] | None = None,
        joint_offsets: Sequence[tuple[str | int, str, float]] | None = None,
        laser_tilt_deg: float | tuple[float, float] | None = None,
    ) -> None:
        rig = as_rig(rig)
        self.rig = rig
        chosen = effects_from(effects, rig)
        # The keyword forms of the geometric effects, kept for existing callers.
        if alpha_by_temperature:
            chosen.append(AlphaPerLink(alpha_per_k=dict(alpha_by_temperature)))
        if kappa_per_k:
            chosen.append(NonlinearAlpha(kappa_per_k=float(kappa_per_k)))
        for length, temperature in (extra_lengths or {}).items():
            chosen.append(UnmodelledLength(length=length, temperature=temperature))
        for joint, temperature, urad_per_k in joint_offsets or ():
            name = self.rig.joint_names[self._joint_index(joint)]
            chosen.append(JointOffset(joint=name, temperature=temperature, urad_per_k=urad_per_k))
        if laser_tilt_deg is not None:
            tilt, az = (
                laser_tilt_deg if isinstance(laser_tilt_deg, tuple) else (laser_tilt_deg, 0.0)
            )
            chosen.append(LaserTilt(tilt_deg=float(tilt), azimuth_deg=float(az)))
        self.effects: tuple[Effect, ...] = tuple(chosen)
        self._native = _native.ForwardModel(
            rig._native,
            alpha_per_k=alpha_per_k,
            reference_c=reference_c,
            effects_json=to_json(chosen),
        )

    def _joint_index(self, joint: str | int) -> int:
        """0-based index of a joint given by rig name or 1-based number."""
        if isinstance(joint, str):
            if joint not in self.rig.joint_names:
                known = ", ".join(self.rig.joint_names)
                raise InputError(f"joint_offset: {joint!r} is not a rig joint ({known})")
            return self.rig.joint_names.index(joint)
        if not 1 <= int(joint) <= 6:
            raise InputError(f"joint_offset: joint {joint} is not 1..6")
        return int(joint) - 1

    @property
    def temperature_names(self) -> list[str]:
        """The temperatures (ROI names or ``ambient``) the model needs."""
        return self._native.temperature_names()

    # --- input conversion ---------------------------------------------------------------------
    def _prepare(
        self,
        joints_rad: npt.ArrayLike,
        temperatures: Mapping[str, npt.ArrayLike] | None,
    ) -> tuple[FloatArray, list[FloatArray] | None]:
        q = np.asarray(joints_rad, dtype=np.float64)
        if q.ndim not in (1, 2) or q.shape[-1] != 6:
            raise InputError(f"joints_rad must have shape (6,) or (N, 6), got {q.shape}")
        if temperatures is None:
            return np.ascontiguousarray(np.atleast_2d(q)), None
        known = {r.name for r in self.rig.rois} | {"ambient"}
        unknown = sorted(set(temperatures) - known)
        if unknown:
            raise InputError(
                f"temperatures {unknown} are not in the rig (known: {', '.join(sorted(known))})"
            )
        needed = self.temperature_names
        missing = [n for n in needed if n not in temperatures]
        if missing:
            raise InputError(
                f"temperatures {missing} are missing; the rig maps lengths to {needed}"
            )
        cols = [np.asarray(temperatures[n], dtype=np.float64) for n in needed]
        for name, c in zip(needed, cols, strict=True):
            if c.ndim > 1:
                raise InputError(f"temperature {name!r} must be a scalar or 1-D, got {c.shape}")
        n = max([q.shape[0] if q.ndim == 2 else 1] + [c.size for c in cols])
        try:
            q2 = np.ascontiguousarray(np.broadcast_to(q, (n, 6)))
            cols = [np.ascontiguousarray(np.broadcast_to(c, (n,))) for c in cols]
        except ValueError as e:
            raise InputError(f"joints and temperatures do not broadcast to {n} samples: {e}") from e
        return q2, cols

    # --- batches ------------------------------------------------------------------------------
    def flange_positions(
        self,
        joints_rad: npt.ArrayLike,
        *,
        temperatures: Mapping[str, npt.ArrayLike] | None = None,
        progress: Progress | None = None,
    ) -> FloatArray:
        """Flange positions (N, 3) in mm in the base frame.

        Parameters
        ----------
        joints_rad
            Joint values in radians, shape (N, 6), or (6,) for one pose held over time.
        temperatures
            Per mapped temperature name, °C per sample (1-D, length N) or a scalar; ``None``
            for the nominal lengths.
        progress
            Called as ``progress(done, total)`` between chunks of 262,144 samples.
        """
        q, cols = self._prepare(joints_rad, temperatures)
        return self._native.flange_positions(q, cols, progress)

    def flange_transforms(
        self,
        joints_rad: npt.ArrayLike,
        *,
        temperatures: Mapping[str, npt.ArrayLike] | None = None,
        progress: Progress | None = None,
    ) -> FloatArray:
        """Flange transforms (N, 4, 4), homogeneous, in the base frame (mm)."""
        q, cols = self._prepare(joints_rad, temperatures)
        return self._native.flange_transforms(q, cols, progress)

    def spots(
        self,
        camera: str,
        joints_rad: npt.ArrayLike,
        *,
        temperatures: Mapping[str, npt.ArrayLike] | None = None,
        progress: Progress | None = None,
    ) -> Spots:
        """Where the laser meets ``camera``'s chip, per sample (see :class:`Spots`)."""
        cam = self.rig.camera(camera)
        q, cols = self._prepare(joints_rad, temperatures)
        out = self._native.spots(camera, q, cols, progress)
        return Spots(
            camera=camera,
            x_px=out[:, 0],
            y_px=out[:, 1],
            distance_mm=out[:, 2],
            incidence_deg=out[:, 3],
            size_px=cam.size_px,
            pixel_pitch_um=cam.pixel_pitch_um,
        )
