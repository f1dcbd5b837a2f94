"""The thermal camera's own errors as effects: the forward model is right and the
temperatures it is given are not (:class:`InstrumentEffect`). Each corrects the readings
before the forward model sees them, and the diagnoser names it as the instrument to check,
never as a property of the robot: an emissivity set wrong (:class:`IrGain`), an offset that
drifts (:class:`IrDrift`), a clock off (:class:`IrClock`), readings scattering by more than the
analysis' smoother takes out (:class:`IrNoise`). Registered with the effects of SPEC §6
(:mod:`thermrs.effect_base`); :mod:`thermrs.effects`, the face of every effect, imports this
module after its own."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from functools import partial
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np
import numpy.typing as npt

from thermrs.effect_base import (
    _REGISTRY,
    Effect,
    _ci,
    _ratio_ci,
    register,
    share_family,
)
from thermrs.effect_family import Family, Visits
from thermrs.errors import InputError

if TYPE_CHECKING:
    from thermrs.rig import Rig

__all__ = [
    "INSTRUMENT_EFFECTS",
    "InstrumentEffect",
    "IrClock",
    "IrDrift",
    "IrGain",
    "IrNoise",
    "clock_shifted",
    "is_instrument",
    "smoothed_readings",
]

FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True)
class InstrumentEffect(Effect):
    """An error of the thermal camera's readings, not of the robot: the forward model is
    right and the temperatures it is given are not. Each corrects the readings
    (:meth:`corrected`) before the forward model sees them; the diagnoser names it as the
    instrument to check, never as a property of the robot. Not SPEC §6 effects: the
    simulator does not write them (the independent bench world does)."""

    #: An instrument's effect (the report and the verdict say "check the thermography").
    instrument: ClassVar[bool] = True
    #: The largest plausible size of the effect's parameter (beyond it, the readings are not
    #: miscalibrated but wrong: a ROI on the wrong link, a clock set to another zone).
    bound: ClassVar[float] = np.inf
    #: The key of the parameter :attr:`bound` applies to.
    size_key: ClassVar[str] = ""

    def corrected(
        self, temps: Mapping[str, FloatArray], visits: Any, reference_c: float
    ) -> dict[str, FloatArray]:
        """The readings as they would have been without this error (``visits``: their run,
        ``t_s`` and ``t_since_start`` per visit, as :class:`thermrs.signatures.VisitSet`)."""
        raise NotImplementedError

    def check(self, rig: Rig | None = None) -> Effect:
        """Validate the size (and, with ``rig``, the ROI it names)."""
        size = float(getattr(self, self.size_key))
        if not np.isfinite(size) or abs(size) > self.bound:
            raise InputError(
                f"effect {self.name}: {self.size_key} = {size} is beyond ±{self.bound:g}, more "
                "than a miscalibrated instrument"
            )
        roi = getattr(self, "roi", None)
        if rig is not None and roi is not None and roi not in [r.name for r in rig.rois]:
            raise InputError(f"effect {self.name}: the rig has no ROI {roi!r}")
        return self

    #: The rig's ``[tolerances]`` key stating this instrument's calibration, and the factor
    #: on it below which a fitted error is within the statement (``""``: no statement).
    tolerance_key: ClassVar[str] = ""

    def beyond_statement(self, rig: Rig) -> bool:
        """Whether the error exceeds twice the rig's stated tolerance of it (the size a
        rig that understates its errors twofold would have): only then is it the
        instrument's error rather than its stated uncertainty."""
        tol = float(rig.tolerances.get(self.tolerance_key, 0.0)) if self.tolerance_key else 0.0
        return abs(float(getattr(self, self.size_key))) > 2.0 * tol

    @classmethod
    def _families(
        cls,
        rig: Rig,
        visits: Visits,
        make: Callable[..., InstrumentEffect],
        unit: float,
        transform: Callable[[float], float] | None = None,
    ) -> list[Family]:
        """Per ROI the runs carry (``make(roi, size)``), or one for the camera (``make(size)``
        for a class without ``roi``): one column, the spots' move per unit α when the effect
        is ``unit`` large; its parameter the amplitude over α, mapped by ``transform``
        (increasing) where the correction is not linear in it."""

        def family(label: str, choices: dict[str, Any], one: Callable[[float], Any]) -> Family:
            def columns(vs: Visits, eta: dict[str, float]) -> FloatArray:
                moved = vs.positions(effects=[one(unit)])
                return ((moved - vs.positions()) / (unit * vs.alpha0))[:, None]

            def params(
                eta: dict[str, float], alpha: float, beta: FloatArray, cov: FloatArray
            ) -> tuple[dict[str, Any], dict[str, Any]]:
                k, sd = _ratio_ci(float(beta[0]), alpha, cov, 1, 0)
                ci = _ci(k, sd)
                if transform is not None:
                    k, ci = transform(k), [transform(ci[0]), transform(ci[1])]
                return {**choices, cls.size_key: k}, {cls.size_key: ci}

            return Family(cls.name, label, choices, [{}], columns, params, driver="instrument")

        rois = [r for r in rig.mapped_temperatures if r != "ambient" and visits.has(r)]
        if "roi" not in {f.name for f in dataclasses.fields(cls)}:
            return [family(cls.name, {}, make)] if rois else []
        return [family(f"{cls.name} roi={r}", {"roi": r}, partial(make, r)) for r in rois]


@register
@dataclass(frozen=True)
class IrGain(InstrumentEffect):
    """One ROI reads its rise above the room ``1 + gain`` times too large (an emissivity set
    wrong for that surface): ``T_read − room = (1 + gain)·(T − room)``."""

    name: ClassVar[str] = "ir_gain"
    bound: ClassVar[float] = 0.5
    size_key: ClassVar[str] = "gain"
    tolerance_key: ClassVar[str] = "ir_gain"
    roi: str = ""
    gain: float = 0.0

    def corrected(
        self, temps: Mapping[str, FloatArray], visits: Any, reference_c: float
    ) -> dict[str, FloatArray]:
        out = dict(temps)
        t = temps[self.roi]
        amb = temps.get("ambient")
        room = amb if amb is not None else np.full(len(t), reference_c)
        out[self.roi] = room + (t - room) / (1.0 + self.gain)
        return out

    @classmethod
    def families(cls, rig: Rig, visits: Visits) -> list[Family]:
        unit = 0.01

        def gain(x: float) -> float:
            # The column moves the reading by −rise·u/(1 + u) per unit u; the fit's share x of
            # it corrects by −rise·x·u/(1 + u)/u, and a gain g corrects by −rise·g/(1 + g).
            c = x / (1.0 + unit)
            return c / (1.0 - c) if c < 1.0 else np.inf

        return cls._families(rig, visits, lambda r, g: IrGain(roi=r, gain=g), unit, gain)


@register
@dataclass(frozen=True)
class IrDrift(InstrumentEffect):
    """One ROI's reading drifts by ``k_per_h`` kelvin per hour since its run began (an
    uncorrected offset drift of the camera)."""

    name: ClassVar[str] = "ir_drift"
    bound: ClassVar[float] = 2.0
    size_key: ClassVar[str] = "k_per_h"
    roi: str = ""
    k_per_h: float = 0.0

    def corrected(
        self, temps: Mapping[str, FloatArray], visits: Any, reference_c: float
    ) -> dict[str, FloatArray]:
        out = dict(temps)
        out[self.roi] = temps[self.roi] - self.k_per_h * visits.t_since_start / 3600.0
        return out

    @classmethod
    def families(cls, rig: Rig, visits: Visits) -> list[Family]:
        return cls._families(rig, visits, lambda r, k: IrDrift(roi=r, k_per_h=k), 0.1)


@register
@dataclass(frozen=True)
class IrClock(InstrumentEffect):
    """The thermal camera's frames are stamped ``s`` seconds late against the CCD cameras'
    (its reading at t was taken at t − s): every ROI's reading belongs ``s`` earlier."""

    name: ClassVar[str] = "ir_clock"
    bound: ClassVar[float] = 600.0
    size_key: ClassVar[str] = "s"
    tolerance_key: ClassVar[str] = "ir_clock_s"
    s: float = 0.0

    def corrected(
        self, temps: Mapping[str, FloatArray], visits: Any, reference_c: float
    ) -> dict[str, FloatArray]:
        """Each reading moved by the change of the run's heating curve over ``s``
        (:func:`clock_shifted`): the signal is shifted, the reading's own noise is not."""
        out = dict(temps)
        for name, t in temps.items():
            if name == "ambient":
                continue
            fixed = t.copy()
            for r in np.unique(visits.run):
                m = np.flatnonzero(visits.run == r)
                order = m[np.argsort(visits.t_s[m], kind="stable")]
                fixed[order] = clock_shifted(visits.t_s[order], t[order], self.s)
            out[name] = fixed
        return out

    @classmethod
    def families(cls, rig: Rig, visits: Visits) -> list[Family]:
        return cls._families(rig, visits, lambda x: IrClock(s=x), 10.0)


@register
@dataclass(frozen=True)
class IrNoise(InstrumentEffect):
    """The thermal camera's readings scatter from visit to visit by more than the analysis'
    own smoother takes out (reflections, a ROI on an edge, a noisy detector): the readings
    the structure follows are those smoothed symmetrically over ± ``half_width_min``
    (:func:`smoothed_readings`), ``weight`` (default 1) the share of that smoothing the data
    ask for. A symmetric smoother has no phase: where a thermal lag (which lags) and this
    explain runs alike, the data cannot tell a lag of the structure from the camera's noise."""

    name: ClassVar[str] = "ir_noise"
    bound: ClassVar[float] = 2.0
    size_key: ClassVar[str] = "weight"
    half_width_min: float = 0.0
    weight: float = 1.0

    def corrected(
        self, temps: Mapping[str, FloatArray], visits: Any, reference_c: float
    ) -> dict[str, FloatArray]:
        out = dict(temps)
        if self.half_width_min <= 0 or self.weight == 0:
            return out
        for name, t in temps.items():
            if name == "ambient":
                continue
            smooth = smoothed_readings(visits, t, 60.0 * self.half_width_min)
            out[name] = t + self.weight * (smooth - t)
        return out

    @classmethod
    def families(cls, rig: Rig, visits: Visits) -> list[Family]:
        rois = [r for r in rig.mapped_temperatures if r != "ambient" and visits.has(r)]
        if not rois:
            return []

        def make(half_width_min: float) -> Effect:
            return IrNoise(half_width_min=half_width_min)

        return [share_family(cls.name, "half_width_min", make, "instrument")]


def smoothed_readings(visits: Any, y: FloatArray, half_width_s: float) -> FloatArray:
    """One temperature's readings (every visit of ``visits``) smoothed per (run, camera)
    series by a local quadratic of half-width ``half_width_s`` (:func:`thermrs.stats.loess2`,
    as the diagnosis smooths the readings it is given)."""
    from thermrs.stats import loess2  # the fit is the analysis's; effects only name it

    out = np.asarray(y, dtype=np.float64).copy()
    cams = getattr(visits, "camera", None)
    key = (
        visits.run
        if cams is None
        else np.char.add(np.char.add(visits.run.astype(str), "\0"), cams.astype(str))
    )
    for k in np.unique(key):
        m = np.flatnonzero(key == k)
        order = m[np.argsort(visits.t_s[m], kind="stable")]
        out[order] = loess2(visits.t_s[order], out[order], half_width_s)
    return out


#: Half-width (s) of the local quadratic whose change over a clock offset moves a reading:
#: three times the largest plausible offset (:attr:`IrClock.bound`), so that t + s stays well
#: inside the window fitted around t.
CLOCK_CURVE_HALF_WIDTH_S = 3.0 * IrClock.bound


def clock_shifted(t_s: FloatArray, y: FloatArray, s: float) -> FloatArray:
    """The readings ``y`` (at the sorted times ``t_s`` of one run) as read ``s`` seconds
    later: each moves by the change of the run's heating curve over ``s`` — a local quadratic
    (:func:`thermrs.stats.loess2`, half-width :data:`CLOCK_CURVE_HALF_WIDTH_S`), held at the
    run's ends. Interpolating between the readings themselves would average their noise
    (above all between two cameras' visits), and the noise so taken off the model's
    prediction would read as a clock error in every run."""
    from thermrs.stats import loess2  # the fit is the analysis's; effects only name it

    if s == 0.0 or len(y) < 2:
        return np.asarray(y, dtype=np.float64).copy()
    curve = loess2(t_s, np.asarray(y, dtype=np.float64), CLOCK_CURVE_HALF_WIDTH_S)
    return np.asarray(y + np.interp(t_s + s, t_s, curve) - curve, dtype=np.float64)


#: The instrument effects' names (the thermal camera's, not the robot's).
INSTRUMENT_EFFECTS: tuple[str, ...] = ("ir_gain", "ir_drift", "ir_clock", "ir_noise")


def is_instrument(name: str) -> bool:
    """Whether ``name`` is an instrument's effect (module :class:`InstrumentEffect`)."""
    cls = _REGISTRY.get(name)
    return cls is not None and bool(getattr(cls, "instrument", False))
