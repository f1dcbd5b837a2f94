"""What every effect is, apart from which: the base class of the effects (:class:`Effect`, a
frozen dataclass of its JSON keys), the registry every effect class is entered in
(:func:`register`), the profiled time constants, and the helpers the families read their
fitted amplitudes back with. The effects of SPEC §6 are in :mod:`thermrs.effects`, the
thermal camera's own errors in :mod:`thermrs.instruments`; :mod:`thermrs.effects` is the
face of all of them."""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np
import numpy.typing as npt

import thermrs._native as _native
from thermrs.effect_family import Family, Visits

if TYPE_CHECKING:
    from thermrs.rig import Rig

__all__ = [
    "EFFECT_NAMES",
    "MOUNT_TAU_GRID_MIN",
    "TAU_GRID_MIN",
    "Effect",
    "register",
    "share_family",
]

FloatArray = npt.NDArray[np.float64]

#: SPEC §6 names, in the SPEC's order (from the Rust core).
EFFECT_NAMES: tuple[str, ...] = tuple(_native.effect_names())

#: Time constants (min) the diagnoser profiles for first-order effects (then refines).
TAU_GRID_MIN: tuple[float, ...] = (3, 6, 10, 15, 22, 33, 50, 75, 110, 160, 240, 360, 540)
#: A camera mount's time constants (min) the diagnoser profiles ``fixture_drift`` over: from
#: one that follows the room within a cycle to a heavy bracket's hour and more.
MOUNT_TAU_GRID_MIN: tuple[float, ...] = (0.5, 4, 12, 35, 100)


@dataclass(frozen=True)
class Effect:
    """Base of every SPEC §6 effect: a frozen dataclass of the SPEC's JSON keys."""

    name: ClassVar[str] = ""

    def to_dict(self) -> dict[str, Any]:
        """The SPEC §6 JSON shape: ``{"name": …, key: value, …}``."""
        d: dict[str, Any] = {"name": self.name}
        for f in dataclasses.fields(self):
            v = getattr(self, f.name)
            d[f.name] = (
                list(v) if isinstance(v, tuple) else dict(v) if isinstance(v, Mapping) else v
            )
        return d

    def check(self, rig: Rig | None = None) -> Effect:
        """Validate the values (and, with ``rig``, the names they use) in the Rust core.

        Raises
        ------
        InputError
            A value out of range or a name the rig does not have; the message names the key.
        """
        if self.name in _native.effect_names():
            _native.effect_check(json.dumps(self.to_dict()), None if rig is None else rig._native)
        return self

    @classmethod
    def families(cls, rig: Rig, visits: Visits) -> list[Family]:
        """The diagnoser's families of this effect on these runs (none by default)."""
        return []


_REGISTRY: dict[str, type[Effect]] = {}


def register(cls: type[Effect]) -> type[Effect]:
    """Register an effect class under its ``name`` (a decorator)."""
    if not cls.name:
        raise TypeError(f"{cls.__name__} has no `name`")
    _REGISTRY[cls.name] = cls
    return cls


def _ci(v: float, sd: float) -> list[float]:
    return [v - 1.96 * sd, v + 1.96 * sd]


def _sd(cov: FloatArray, i: int) -> float:
    return float(np.sqrt(max(cov[i, i], 0.0)))


def _ratio_ci(num: float, den: float, cov: FloatArray, i: int, j: int) -> tuple[float, float]:
    """num/den (den = α at index j) and its standard deviation by the delta method."""
    r = num / den
    g = np.zeros(cov.shape[0])
    g[i] = 1.0 / den
    g[j] = -num / den**2
    return r, float(np.sqrt(max(float(g @ cov @ g), 0.0)))


def share_family(
    name: str,
    key: str,
    make: Callable[[float], Effect],
    driver: str,
) -> Family:
    """The family of an effect that acts through one time constant (``key``, minutes, on
    :data:`TAU_GRID_MIN`, refined), of which the data ask a share: its column is the whole
    effect's move per unit α (``make(x)``: the effect at that time constant), its fitted
    amplitude over α the share (``weight``, with its interval)."""

    def columns(vs: Visits, eta: dict[str, float]) -> FloatArray:
        moved = vs.positions(effects=[make(eta[key])])
        return ((moved - vs.positions()) / vs.alpha0)[:, None]

    def params(
        eta: dict[str, float], alpha: float, beta: FloatArray, cov: FloatArray
    ) -> tuple[dict[str, Any], dict[str, Any]]:
        # The column is the whole effect's departure per unit α: its amplitude over α is the
        # share, which the effect carries so that what the diagnosis fitted is what a law or a
        # prediction from it applies.
        w, sd = _ratio_ci(float(beta[0]), alpha, cov, 1, 0)
        return {key: eta[key], "weight": w}, {"weight": _ci(w, sd)}

    grid = [{key: float(t)} for t in TAU_GRID_MIN]
    return Family(name, name, {}, grid, columns, params, driver=driver, refine=(key,))
