"""The bench world's thermal physics, independent of :mod:`thermrs.heat`, the simulator and the
diagnoser's families.

Every ROI of the rig is a link with two coupled nodes (a motor/gearbox node heated by the
robot's motion, and the link's surface the IR camera sees), both exchanging heat with the
room, neighbouring links' surfaces coupled to each other. The room's temperature drifts within
a day and differs from day to day (a level, a slope and an HVAC swing). The structure that
expands may lag its surface (SPEC §6 ``thermal_lag``): one first-order node behind the surface,
or two in parallel with two time constants. All of it is one linear system integrated exactly
(matrix exponential) on a fine grid with piecewise-constant inputs.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy.linalg import expm

FloatArray = npt.NDArray[np.float64]

__all__ = ["Ambient", "Links", "draw_ambient", "draw_links", "simulate_day"]

#: Fine-grid step (s) of the thermal integration; visits are interpolated from it.
STEP_S = 60.0


@dataclass(frozen=True)
class Links:
    """The links' thermal parameters (rates per minute; ``heat`` per unit drive)."""

    names: tuple[str, ...]
    k_ms: FloatArray  # motor ↔ surface
    k_ma: FloatArray  # motor ↔ room
    k_sa: FloatArray  # surface ↔ room
    k_ss: float  # surface ↔ neighbouring surface
    capacity_ratio: FloatArray  # motor capacity / surface capacity
    heat: FloatArray  # K/min of motor heating per unit drive


@dataclass(frozen=True)
class Ambient:
    """One day's room temperature: level (°C), slope (K/h), HVAC swing (K, min, rad)."""

    level_c: float
    slope_k_per_h: float
    swing_k: float
    period_min: float
    phase: float

    def at(self, t_s: FloatArray) -> FloatArray:
        """°C at seconds since the day began."""
        h = t_s / 3600.0
        swing = self.swing_k * np.sin(2 * np.pi * t_s / (60 * self.period_min) + self.phase)
        return np.asarray(self.level_c + self.slope_k_per_h * h + swing, dtype=np.float64)


def drive(speed: float) -> float:
    """Heat drive of a speed (fraction of full): a standstill share plus a concave rise."""
    return float(0.15 + np.sqrt(speed))


def draw_links(names: tuple[str, ...], rng: np.random.Generator) -> Links:
    """Thermal parameters for the ROIs ``names``: slow surfaces (~5–7 h), faster motors
    (~40 min), the first two ROIs' steady rise at 30 % speed drawn between 3 and 7 K, any
    further ROI's (e.g. a base) between 0.5 and 1.5 K."""
    n = len(names)
    k_ms = 1.0 / rng.uniform(30.0, 60.0, n)
    k_ma = 1.0 / rng.uniform(150.0, 300.0, n)
    k_sa = 1.0 / rng.uniform(330.0, 480.0, n)
    ratio = rng.uniform(0.15, 0.3, n)
    rise = np.where(np.arange(n) < 2, rng.uniform(3.0, 7.0, n), rng.uniform(0.5, 1.5, n))
    base = Links(names, k_ms, k_ma, k_sa, 1.0 / 1500.0, ratio, np.ones(n))
    # Scale the heat so the steady surface rise at 30 % is the drawn one.
    a, b = _system(base, ())
    ss = -np.linalg.solve(a, b[:, 1:] @ np.full(n, drive(0.3)))
    return Links(names, k_ms, k_ma, k_sa, base.k_ss, ratio, rise / ss[n : 2 * n])


def draw_ambient(rng: np.random.Generator, level_c: float | None = None) -> Ambient:
    """A day's room: level 22.5–24 °C, slope 0.03–0.15 K/h (either sign), an HVAC swing of
    0.03–0.15 K with a 1.5–3 h period."""
    return Ambient(
        level_c=rng.uniform(22.5, 24.0) if level_c is None else level_c,
        slope_k_per_h=rng.choice([-1.0, 1.0]) * rng.uniform(0.03, 0.15),
        swing_k=rng.uniform(0.03, 0.15),
        period_min=rng.uniform(90.0, 180.0),
        phase=rng.uniform(0, 2 * np.pi),
    )


def _system(links: Links, lags: tuple[tuple[float, float], ...]) -> tuple[FloatArray, FloatArray]:
    """State matrix A and input matrix B (inputs: room, then each link's drive), per minute.

    State: motors (n), surfaces (n), then per lag component (τ min, weight) n structure
    nodes following the surfaces."""
    n = len(links.names)
    m = 2 * n + n * len(lags)
    a = np.zeros((m, m))
    b = np.zeros((m, 1 + n))
    for i in range(n):
        mi, si = i, n + i
        a[mi, mi] = -(links.k_ms[i] + links.k_ma[i])
        a[mi, si] = links.k_ms[i]
        b[mi, 0] = links.k_ma[i]
        b[mi, 1 + i] = links.heat[i]
        c = links.capacity_ratio[i]
        a[si, mi] = c * links.k_ms[i]
        a[si, si] = -(c * links.k_ms[i] + links.k_sa[i])
        b[si, 0] = links.k_sa[i]
        for j in (i - 1, i + 1):
            if 0 <= j < n:
                a[si, n + j] += links.k_ss
                a[si, si] -= links.k_ss
        for li, (tau, _w) in enumerate(lags):
            k = 2 * n + li * n + i
            a[k, k] = -1.0 / tau
            a[k, si] = 1.0 / tau
    return a, b


def simulate_day(
    links: Links,
    ambient: Ambient,
    plan: list[tuple[float, float]],
    *,
    lags: tuple[tuple[float, float], ...] = (),
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """A day of runs back to back, from equilibrium with the room.

    Parameters
    ----------
    links, ambient
        The thermal parameters and the day's room.
    plan
        (speed fraction, duration s) of each run in order, each straight after the last.
    lags
        The structure's lag behind the surface: (τ min, weight) per component (weights sum to
        1); empty: the structure is at its surface's temperature.

    Returns
    -------
    t_s, room_c, surface_c, structure_c
        The fine grid (s since the day began), the room (°C), the surfaces and the structures
        (°C, shape (n_links, len(t_s))).
    """
    n = len(links.names)
    total = sum(d for _, d in plan)
    t = np.arange(0.0, total + 2 * STEP_S, STEP_S)
    room = ambient.at(t)
    a, b = _system(links, lags)
    e = expm(a * STEP_S / 60.0)
    x = np.full(a.shape[0], room[0])
    out = np.empty((a.shape[0], t.size))
    out[:, 0] = x
    ends = np.cumsum([d for _, d in plan])
    speeds = np.array([drive(s) for s, _ in plan])
    mid = 0.5 * (t[1:] + t[:-1])
    run = np.minimum(np.searchsorted(ends, mid, side="right"), len(plan) - 1)
    u = np.column_stack([0.5 * (room[1:] + room[:-1]), np.repeat(speeds[run][:, None], n, 1)])
    steady = -np.linalg.solve(a, b @ u.T)  # the equilibrium each step's inputs pull towards
    for k in range(1, t.size):
        ss = steady[:, k - 1]
        x = ss + e @ (x - ss)
        out[:, k] = x
    surface = out[n : 2 * n]
    if lags:
        structure = sum(
            w * out[2 * n + li * n : 2 * n + (li + 1) * n] for li, (_, w) in enumerate(lags)
        )
        structure = np.asarray(structure, dtype=np.float64)
    else:
        structure = surface.copy()
    return t, room, surface, structure
