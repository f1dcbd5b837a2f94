"""What the diagnoser asks of an effect: the runs' visits it reads (:class:`Visits`) and the
families it answers with (:class:`Family`: one way the effect can act on given runs, its
signature columns and how its fitted amplitudes read back as its SPEC parameters).

:mod:`thermrs.effects` holds the effects; this module only the shapes they share with the
diagnoser, free of the forward model (``signatures`` imports ``model``, which imports
:mod:`thermrs.effects`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
import numpy.typing as npt

__all__ = ["Family", "Visits"]

FloatArray = npt.NDArray[np.float64]


class Visits(Protocol):
    """What an effect's families read of the runs' visits.

    :class:`thermrs.signatures.VisitSet` is the one the diagnoser passes. Typing the families
    with this protocol keeps this module free of the forward model (``signatures`` imports
    ``model``, which imports this module).
    """

    @property
    def alpha0(self) -> float:
        """The rig's α (1/K), the model's nominal value."""
        ...

    def has(self, name: str) -> bool:
        """Whether every visit has the temperature ``name`` (a ROI or ``ambient``)."""
        ...

    def positions(self, *, effects: Sequence[Any] = ()) -> FloatArray:
        """Every visit's spot (u then v, µm) at its camera's taught pose under ``effects``
        (:class:`thermrs.effects.Effect` objects)."""
        ...

    def alpha_column(self, *, only: str | None = None) -> FloatArray:
        """The spot's displacement per unit α (u then v), from every mapped temperature or
        from ``only`` that one."""
        ...


@dataclass(frozen=True)
class Family:
    """One way an effect can act on given runs, for the diagnoser.

    An effect with discrete choices (a camera, a joint and a temperature) has one family per
    choice; within a family the diagnoser profiles ``grid`` (non-linear parameters such as a
    time constant, a list of dicts; ``[{}]`` for none) and fits the amplitudes of the signature
    columns by linear least squares beside α and the offsets.

    Attributes
    ----------
    effect
        The SPEC §6 name.
    label
        A short human label, e.g. ``"sensor_drift camera=A"``.
    choices
        The fixed discrete parameters (SPEC keys), e.g. ``{"camera": "A"}``.
    grid
        Non-linear parameter values to profile, e.g. ``[{"tau_min": 3.0}, …]``.
    columns
        ``columns(visits, eta) -> (2n, k)`` array: the effect's signature per unit amplitude
        on every visit's u (first n rows) and v (next n rows), from the nominal model at the
        rig's α.
    params
        ``params(eta, alpha, beta, cov) -> (params, ci95)``: the effect's SPEC parameters from
        the fitted α, amplitudes ``beta`` and their covariance (α first), with 95 % intervals
        where they can be given.
    driver
        What the signature follows in time (for the placebo and the report), e.g. ``"link2"``,
        ``"ambient"``, ``"time"``.
    refine
        Names of ``grid`` keys that may be refined continuously between grid points.
    """

    effect: str
    label: str
    choices: dict[str, Any]
    grid: list[dict[str, float]]
    columns: Callable[[Visits, dict[str, float]], FloatArray]
    params: Callable[
        [dict[str, float], float, FloatArray, FloatArray],
        tuple[dict[str, Any], dict[str, Any]],
    ]
    driver: str = "temperature"
    refine: tuple[str, ...] = ()
