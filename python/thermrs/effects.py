"""The unmodelled effects of SPEC §6, as Python objects.

Each effect is a frozen dataclass whose fields are the SPEC's JSON keys. Its parameters are
validated, and its action on the forward model is carried out, in one place: the Rust core's
``effects`` module (``thermrs._native``), which the simulator uses too. This module is the face
of that home for Python:

- build effects (``ThermalLag(tau_min=25.0)``) or read them (:func:`from_dict`, the JSON shape
  of SPEC §6 and of scenario files' ``[[effect]]`` tables);
- give them to :class:`thermrs.ForwardModel` (``effects=[...]``), which moves the spot as the
  effect does;
- the diagnoser (:mod:`thermrs.diagnose`) asks each effect class for its *families*
  (:meth:`Effect.families`): the effect's discrete choices (which camera, joint, length,
  temperature) and its profiled non-linear parameters (time constants), each family giving the
  signature columns the effect adds to the nominal model and reading its fitted amplitudes
  back as the effect's SPEC parameters.

Adding an effect: a variant in ``rust/thermrs-core/src/effects/mod.rs``, a class here (registered
with :func:`register`), and a row in the SPEC table. A user may also register an effect of their
own whose :meth:`Effect.families` compute signature columns in Python; the diagnoser treats it
like the built-in ones.

Example
-------
>>> import thermrs
>>> from thermrs.effects import ThermalLag, from_dict
>>> lag = from_dict({"name": "thermal_lag", "tau_min": 25.0})
>>> lag == ThermalLag(tau_min=25.0)
True
>>> lag.to_dict()
{'name': 'thermal_lag', 'tau_min': 25.0}
"""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np
import numpy.typing as npt

import thermrs._native as _native
from thermrs.effect_base import (
    _REGISTRY,
    EFFECT_NAMES,
    MOUNT_TAU_GRID_MIN,
    TAU_GRID_MIN,
    Effect,
    _ci,
    _ratio_ci,
    _sd,
    register,
    share_family,
)
from thermrs.effect_family import Family, Visits
from thermrs.errors import InputError

if TYPE_CHECKING:
    from thermrs.rig import Rig

__all__ = [
    "EFFECT_NAMES",
    "INSTRUMENT_EFFECTS",
    "AlphaPerLink",
    "Effect",
    "Family",
    "FixtureDrift",
    "InstrumentEffect",
    "IrClock",
    "IrDrift",
    "IrGain",
    "IrNoise",
    "JointOffset",
    "LaserTilt",
    "NonlinearAlpha",
    "SensorDrift",
    "ThermalLag",
    "UnmodelledLength",
    "Visits",
    "effect_classes",
    "from_dict",
    "is_instrument",
    "register",
]

FloatArray = npt.NDArray[np.float64]


def effect_classes() -> dict[str, type[Effect]]:
    """Every registered effect class by name (SPEC §6 first, in the SPEC's order)."""
    return dict(_REGISTRY)


def from_dict(d: Mapping[str, Any], *, rig: Rig | None = None) -> Effect:
    """An effect from its SPEC §6 JSON shape (``{"name": "thermal_lag", "tau_min": 25}``),
    validated (and checked against ``rig`` if given).

    Raises
    ------
    InputError
        Unknown name, a missing or unknown key, a value out of range.
    """
    if not isinstance(d, Mapping) or "name" not in d:
        raise InputError(f"an effect needs a `name`, got {d!r}")
    name = str(d["name"])
    cls = _REGISTRY.get(name)
    if cls is None:
        raise InputError(f"{name!r} is not an effect (known: {', '.join(_REGISTRY)})")
    if name in _native.effect_names():
        d = json.loads(
            _native.effect_check(json.dumps(dict(d)), None if rig is None else rig._native)
        )
    kwargs = {k: v for k, v in d.items() if k != "name"}
    names = {f.name for f in dataclasses.fields(cls)}
    unknown = sorted(set(kwargs) - names)
    if unknown:
        raise InputError(f"effect {name}: unknown keys {unknown} (it takes {sorted(names)})")
    for f in dataclasses.fields(cls):
        if isinstance(kwargs.get(f.name), list):
            kwargs[f.name] = tuple(kwargs[f.name])
    try:
        out = cls(**kwargs)
    except TypeError as e:
        raise InputError(f"effect {name}: {e}") from None
    return out.check(rig) if isinstance(out, InstrumentEffect) else out


def to_json(effects: Iterable[Effect]) -> str:
    """A JSON list of effects for the Rust core."""
    return json.dumps([e.to_dict() for e in effects if e.name in EFFECT_NAMES])


# --- signature helpers ---------------------------------------------------------------------------


#: The largest |κ| (1/K) of ``nonlinear_alpha`` the core accepts (its physical bound).
KAPPA_PER_K_MAX = 0.1


# --- the SPEC §6 effects -------------------------------------------------------------------------


@register
@dataclass(frozen=True)
class AlphaPerLink(Effect):
    """Each mapped temperature has its own α (1/K)."""

    name: ClassVar[str] = "alpha_per_link"
    alpha_per_k: Mapping[str, float] = field(default_factory=dict)

    @classmethod
    def families(cls, rig: Rig, visits: Visits) -> list[Family]:
        temps = list(dict.fromkeys(rig.mapped_temperatures))
        if len(temps) < 2:
            return []
        rest = temps[1:]

        def columns(vs: Visits, eta: dict[str, float]) -> FloatArray:
            return np.column_stack([vs.alpha_column(only=t) for t in rest])

        def params(
            eta: dict[str, float], alpha: float, beta: FloatArray, cov: FloatArray
        ) -> tuple[dict[str, Any], dict[str, Any]]:
            vals = {temps[0]: alpha}
            cis = {temps[0]: _ci(alpha, _sd(cov, 0))}
            for k, t in enumerate(rest):
                g = np.zeros(cov.shape[0])
                g[0] = 1.0
                g[1 + k] = 1.0
                vals[t] = alpha + float(beta[k])
                cis[t] = _ci(vals[t], float(np.sqrt(max(float(g @ cov @ g), 0.0))))
            return {"alpha_per_k": vals}, {"alpha_per_k": cis}

        return [Family(cls.name, cls.name, {}, [{}], columns, params, driver=",".join(temps))]


@register
@dataclass(frozen=True)
class ThermalLag(Effect):
    """The structure lags the surface temperature the IR camera sees (first order);
    ``weight`` (an extension, default 1) is the share of the expansion that lags: the
    structure sees T + weight·(lag(T) − T)."""

    name: ClassVar[str] = "thermal_lag"
    tau_min: float = 0.0
    weight: float = 1.0

    def to_dict(self) -> dict[str, Any]:
        d = super().to_dict()
        if self.weight == 1.0:
            d.pop("weight", None)  # SPEC §6's own shape where all of it lags
        return d

    @classmethod
    def families(cls, rig: Rig, visits: Visits) -> list[Family]:
        def make(tau_min: float) -> Effect:
            return ThermalLag(tau_min=tau_min)

        return [share_family(cls.name, "tau_min", make, ",".join(rig.mapped_temperatures))]


def _length_names(rig: Rig) -> list[str]:
    """Every non-zero DH length the rig does not list in ``[expansion]``."""
    listed = {m.name for m in rig.lengths}
    out = []
    for i, row in enumerate(rig.dh, start=1):
        for kind, value in (("a", row.a_mm), ("d", row.d_mm)):
            n = f"{kind}{i}"
            if n not in listed and abs(value) > 1.0:
                out.append(n)
    return out


def _temperature_names(rig: Rig, visits: Visits) -> list[str]:
    """Temperatures the runs carry: every ROI, and ambient where it was recorded."""
    names = [r.name for r in rig.rois]
    if visits.has("ambient"):
        names.append("ambient")
    return [n for n in names if visits.has(n)]


@register
@dataclass(frozen=True)
class UnmodelledLength(Effect):
    """A DH length the rig does not list expands with a temperature; ``weight`` (an
    extension, default 1: the same α) is its α as a multiple of the model's (a part of
    another material)."""

    name: ClassVar[str] = "unmodelled_length"
    length: str = ""
    temperature: str = ""
    weight: float = 1.0

    def to_dict(self) -> dict[str, Any]:
        d = super().to_dict()
        if self.weight == 1.0:
            d.pop("weight", None)  # SPEC §6's own shape where the length has the model's α
        return d

    @classmethod
    def families(cls, rig: Rig, visits: Visits) -> list[Family]:
        fams = []
        for length in _length_names(rig):
            for temp in _temperature_names(rig, visits):
                eff = UnmodelledLength(length=length, temperature=temp)

                def columns(vs: Visits, eta: dict[str, float], eff: Effect = eff) -> FloatArray:
                    return ((vs.positions(effects=[eff]) - vs.positions()) / vs.alpha0)[:, None]

                def params(
                    eta: dict[str, float],
                    alpha: float,
                    beta: FloatArray,
                    cov: FloatArray,
                    length: str = length,
                    temp: str = temp,
                ) -> tuple[dict[str, Any], dict[str, Any]]:
                    # The column is the length expanding at α per unit α: its amplitude over
                    # α is the length's own α over the model's, which the effect carries so
                    # that a law or a prediction applies what the diagnosis fitted.
                    w, sd = _ratio_ci(float(beta[0]), alpha, cov, 1, 0)
                    return {"length": length, "temperature": temp, "weight": w}, {
                        "weight": _ci(w, sd)
                    }

                fams.append(
                    Family(
                        cls.name,
                        f"{cls.name} length={length} temperature={temp}",
                        {"length": length, "temperature": temp},
                        [{}],
                        columns,
                        params,
                        driver=temp,
                    )
                )
        return fams


def _chip_family(
    name: str, rig: Rig, camera: str, grid: list[dict[str, float]], key: str, driver: str
) -> Family:
    """A family whose signature is one camera's chip shift along u and along v."""

    def columns(vs: Visits, eta: dict[str, float]) -> FloatArray:
        cols = []
        for unit in ((1.0, 0.0), (0.0, 1.0)):
            if name == "fixture_drift":
                e: Effect = FixtureDrift(
                    camera=camera, um_per_k=unit, mount_tau_min=eta["mount_tau_min"]
                )
            else:
                e = SensorDrift(camera=camera, tau_min=eta["tau_min"], um=unit)
            cols.append(vs.positions(effects=[e]) - vs.positions())
        return np.column_stack(cols)

    def params(
        eta: dict[str, float], alpha: float, beta: FloatArray, cov: FloatArray
    ) -> tuple[dict[str, Any], dict[str, Any]]:
        vals = [float(beta[0]), float(beta[1])]
        cis = [_ci(vals[0], _sd(cov, 1)), _ci(vals[1], _sd(cov, 2))]
        p: dict[str, Any] = {"camera": camera, **{k: v for k, v in eta.items()}, key: vals}
        return p, {key: cis}

    return Family(
        name,
        f"{name} camera={camera}",
        {"camera": camera},
        grid,
        columns,
        params,
        driver=driver,
        refine=tuple(grid[0]) if grid else (),
    )


@register
@dataclass(frozen=True)
class FixtureDrift(Effect):
    """One camera's mount moves with ambient temperature: ``um_per_k`` [u, v] µm/K, the mount
    following the room through its own first-order inertia ``mount_tau_min`` (an extension of
    SPEC §6; 0: at once)."""

    name: ClassVar[str] = "fixture_drift"
    camera: str = ""
    um_per_k: tuple[float, float] = (0.0, 0.0)
    mount_tau_min: float = 0.0

    def to_dict(self) -> dict[str, Any]:
        d = super().to_dict()
        if not self.mount_tau_min:
            d.pop("mount_tau_min", None)  # SPEC §6's own shape where the mount has no lag
        return d

    @classmethod
    def families(cls, rig: Rig, visits: Visits) -> list[Family]:
        if not visits.has("ambient"):
            return []
        grid = [{"mount_tau_min": float(t)} for t in MOUNT_TAU_GRID_MIN]
        return [
            _chip_family(cls.name, rig, c.name, grid, "um_per_k", "ambient") for c in rig.cameras
        ]


@register
@dataclass(frozen=True)
class LaserTilt(Effect):
    """The true laser direction is the rig's turned by ``tilt_deg`` (about an axis turned by
    ``azimuth_deg`` about the ray; an extension of SPEC §6)."""

    name: ClassVar[str] = "laser_tilt"
    tilt_deg: float = 0.0
    azimuth_deg: float = 0.0

    @classmethod
    def families(cls, rig: Rig, visits: Visits) -> list[Family]:
        step = 0.05

        def columns(vs: Visits, eta: dict[str, float]) -> FloatArray:
            cols = []
            for az in (0.0, 90.0):
                tilted = vs.positions(effects=[LaserTilt(tilt_deg=step, azimuth_deg=az)])
                cols.append((tilted - vs.positions()) / step)
            return np.column_stack(cols)

        def params(
            eta: dict[str, float], alpha: float, beta: FloatArray, cov: FloatArray
        ) -> tuple[dict[str, Any], dict[str, Any]]:
            b0, b1 = float(beta[0]), float(beta[1])
            tilt = float(np.hypot(b0, b1))
            az = float(np.degrees(np.arctan2(b1, b0)))
            sd = float(np.sqrt(max((cov[1, 1] + cov[2, 2]) / 2.0, 0.0)))
            return {"tilt_deg": tilt, "azimuth_deg": az}, {"tilt_deg": _ci(tilt, sd)}

        return [Family(cls.name, cls.name, {}, [{}], columns, params, driver="geometry")]


@register
@dataclass(frozen=True)
class JointOffset(Effect):
    """A joint's zero drifts by ``urad_per_k`` per kelvin of a temperature."""

    name: ClassVar[str] = "joint_offset"
    joint: str = ""
    temperature: str = ""
    urad_per_k: float = 0.0

    @classmethod
    def families(cls, rig: Rig, visits: Visits) -> list[Family]:
        fams = []
        for joint in rig.joint_names:
            for temp in _temperature_names(rig, visits):
                unit = JointOffset(joint=joint, temperature=temp, urad_per_k=1.0)

                def columns(vs: Visits, eta: dict[str, float], unit: Effect = unit) -> FloatArray:
                    return (vs.positions(effects=[unit]) - vs.positions())[:, None]

                def params(
                    eta: dict[str, float],
                    alpha: float,
                    beta: FloatArray,
                    cov: FloatArray,
                    joint: str = joint,
                    temp: str = temp,
                ) -> tuple[dict[str, Any], dict[str, Any]]:
                    v = float(beta[0])
                    return (
                        {"joint": joint, "temperature": temp, "urad_per_k": v},
                        {"urad_per_k": _ci(v, _sd(cov, 1))},
                    )

                fams.append(
                    Family(
                        cls.name,
                        f"{cls.name} joint={joint} temperature={temp}",
                        {"joint": joint, "temperature": temp},
                        [{}],
                        columns,
                        params,
                        driver=temp,
                    )
                )
        return fams


@register
@dataclass(frozen=True)
class NonlinearAlpha(Effect):
    """strain = α·ΔT·(1 + κ·ΔT)."""

    name: ClassVar[str] = "nonlinear_alpha"
    kappa_per_k: float = 0.0

    @classmethod
    def families(cls, rig: Rig, visits: Visits) -> list[Family]:
        step = 1e-3

        def columns(vs: Visits, eta: dict[str, float]) -> FloatArray:
            curved = vs.positions(effects=[NonlinearAlpha(kappa_per_k=step)])
            return ((curved - vs.positions()) / (step * vs.alpha0))[:, None]

        def params(
            eta: dict[str, float], alpha: float, beta: FloatArray, cov: FloatArray
        ) -> tuple[dict[str, Any], dict[str, Any]]:
            k, sd = _ratio_ci(float(beta[0]), alpha, cov, 1, 0)
            ci = _ci(k, sd)
            if ci[0] <= KAPPA_PER_K_MAX and ci[1] >= -KAPPA_PER_K_MAX:
                # An interval that reaches inside the physical bound: what of it lies within
                # (a confidence set cut to the parameter's space keeps its coverage); an
                # estimate past the bound is the bound (the likelihood is quadratic in κ, so
                # the bounded estimate is the bound; a κ at the bound is estimated past it
                # half the time). One wholly past it stays there, and is no physical κ.
                k = float(np.clip(k, -KAPPA_PER_K_MAX, KAPPA_PER_K_MAX))
                ci = [max(ci[0], -KAPPA_PER_K_MAX), min(ci[1], KAPPA_PER_K_MAX)]
            return {"kappa_per_k": k}, {"kappa_per_k": ci}

        return [
            Family(
                cls.name,
                cls.name,
                {},
                [{}],
                columns,
                params,
                driver=",".join(rig.mapped_temperatures),
            )
        ]


@register
@dataclass(frozen=True)
class SensorDrift(Effect):
    """One camera's chip drifts on its own, ``um``·(1 − e^(−t/τ)), t since the run began."""

    name: ClassVar[str] = "sensor_drift"
    camera: str = ""
    tau_min: float = 0.0
    um: tuple[float, float] = (0.0, 0.0)

    @classmethod
    def families(cls, rig: Rig, visits: Visits) -> list[Family]:
        grid = [{"tau_min": float(t)} for t in TAU_GRID_MIN]
        return [_chip_family(cls.name, rig, c.name, grid, "um", "time") for c in rig.cameras]


def effects_from(
    effects: Sequence[Effect | Mapping[str, Any]] | None, rig: Rig | None = None
) -> list[Effect]:
    """Effects given as objects or SPEC §6 dicts, as objects (validated)."""
    out: list[Effect] = []
    for e in effects or ():
        if isinstance(e, Effect):
            out.append(e.check(rig))
        elif isinstance(e, Mapping):
            out.append(from_dict(e, rig=rig))
        else:
            raise TypeError(f"an effect must be a thermrs.effects.Effect or a dict, got {e!r}")
    return out


# The thermal camera's own errors (their own module; registered on import, here, so that every
# name the registry knows is there once this module is).
from thermrs.instruments import (  # noqa: E402
    INSTRUMENT_EFFECTS,
    InstrumentEffect,
    IrClock,
    IrDrift,
    IrGain,
    IrNoise,
    is_instrument,
)
