"""The bench world's effects: each SPEC §6 effect as this world makes it, with one amplitude
that the SNR scaling turns (:mod:`.snr`) and what else a case draws (a camera, a joint, a
direction, a lag's second time constant).

These are not the diagnoser's families. Where physics allows, they are deliberately not the
family's closed form: a chip mount follows the room through its own thermal inertia; a chip's
self-heating runs from power-on and carries on through a run that follows straight after; a
lag may have two time constants; the structure (not the IR surface) drives every
temperature-proportional effect.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from thermrs.bench.world.geometry import WorldRig

__all__ = ["EFFECTS", "Truth", "draw_truth"]

#: SPEC §6 effect names, in the SPEC's order.
EFFECTS = (
    "alpha_per_link",
    "thermal_lag",
    "unmodelled_length",
    "fixture_drift",
    "laser_tilt",
    "joint_offset",
    "nonlinear_alpha",
    "sensor_drift",
)

#: (starting amplitude, largest amplitude the scaling may use) per effect, in its amplitude's
#: unit: relative α spread, τ (min), α_u/α, µm/K, degrees, µrad/K, κ (1/K), µm.
AMPLITUDE: dict[str, tuple[float, float]] = {
    "alpha_per_link": (0.1, 1.0),
    "thermal_lag": (40.0, 720.0),
    "unmodelled_length": (1.0, 6.0),
    "fixture_drift": (5.0, 200.0),
    "laser_tilt": (0.5, 5.0),
    "joint_offset": (5.0, 300.0),
    "nonlinear_alpha": (0.02, 0.1),  # the SPEC's physical bound, |κ| ≤ 0.1/K
    "sensor_drift": (5.0, 200.0),
}


@dataclass(frozen=True)
class Truth:
    """One injected effect: its name, its amplitude and what the case drew for it."""

    name: str
    amplitude: float
    drawn: dict[str, Any] = field(default_factory=dict)

    def scaled(self, amplitude: float) -> Truth:
        """The same effect at another amplitude."""
        return replace(self, amplitude=float(amplitude))

    @property
    def cap(self) -> float:
        """The largest amplitude the SNR scaling may use."""
        return AMPLITUDE[self.name][1]

    def lags(self) -> tuple[tuple[float, float], ...]:
        """(τ min, weight) components of the structure's lag (``thermal_lag`` only)."""
        if self.name != "thermal_lag":
            return ()
        ratio = float(self.drawn.get("ratio", 1.0))
        if ratio == 1.0:
            return ((self.amplitude, 1.0),)
        return ((self.amplitude, 0.5), (self.amplitude * ratio, 0.5))

    def spec(self, alpha_per_k: float) -> dict[str, Any]:
        """The SPEC §6 JSON of this effect (what a right diagnosis reports), given the case's
        true α; a two-time-constant lag reports its weighted mean τ."""
        d = self.drawn
        a = self.amplitude
        if self.name == "alpha_per_link":
            return {
                "name": self.name,
                "alpha_per_k": {t: alpha_per_k * (1 + a * s) for t, s in d["pattern"].items()},
            }
        if self.name == "thermal_lag":
            return {"name": self.name, "tau_min": sum(t * w for t, w in self.lags())}
        if self.name == "unmodelled_length":
            return {
                "name": self.name,
                "length": d["length"],
                "temperature": d["temperature"],
                "weight": a,
            }
        if self.name == "fixture_drift":
            return {
                "name": self.name,
                "camera": d["camera"],
                "um_per_k": [float(x) for x in a * d["dir"]],
                "mount_tau_min": float(d["mount_tau_min"]),
            }
        if self.name == "laser_tilt":
            return {"name": self.name, "tilt_deg": a}
        if self.name == "joint_offset":
            return {
                "name": self.name,
                "joint": d["joint"],
                "temperature": d["temperature"],
                "urad_per_k": a * d["sign"],
            }
        if self.name == "nonlinear_alpha":
            return {"name": self.name, "kappa_per_k": a * d["sign"]}
        return {
            "name": self.name,
            "camera": d["camera"],
            "tau_min": d["tau_min"],
            "um": [float(x) for x in a * d["dir"]],
        }


def _direction(rng: np.random.Generator) -> np.ndarray[Any, np.dtype[np.float64]]:
    ang = rng.uniform(0, 2 * np.pi)
    return np.array([np.cos(ang), np.sin(ang)])


def draw_truth(name: str, rig: WorldRig, rng: np.random.Generator) -> Truth:
    """An effect ``name`` at its starting amplitude, with what it needs drawn for ``rig``.

    Temperature-proportional effects pick one of the rig's mapped link temperatures; a
    joint_offset one of joints 1–5; an unmodelled_length one of the non-zero DH lengths the rig
    does not list (at least 50 mm); chip effects a camera and a direction on the chip; a lag has
    one time constant or, in half the cases, two (the second 4× the first, equal weights).
    """
    links = [t for t in dict.fromkeys(rig.expansion.values()) if t != "ambient"] or list(rig.rois)
    cams = [c.name for c in rig.chips]
    start = AMPLITUDE[name][0]
    drawn: dict[str, Any] = {}
    if name == "alpha_per_link":
        signs = rng.permutation([(-1.0) ** i for i in range(len(links))])
        drawn["pattern"] = dict(zip(links, (float(s) for s in signs), strict=True))
    elif name == "thermal_lag":
        drawn["ratio"] = float(rng.choice([1.0, 4.0]))
    elif name == "unmodelled_length":
        lengths = []
        for ln in rig.unlisted_lengths():
            i = int(ln[1]) - 1
            if abs(rig.a_mm[i] if ln[0] == "a" else rig.d_mm[i]) >= 50.0:
                lengths.append(ln)
        drawn["length"] = str(rng.choice(lengths))
        drawn["temperature"] = str(rng.choice(links))
    elif name in ("fixture_drift", "sensor_drift"):
        drawn["camera"] = str(rng.choice(cams))
        drawn["dir"] = _direction(rng)
        drawn["mount_tau_min"] = float(rng.uniform(10.0, 30.0))
        drawn["tau_min"] = float(rng.uniform(30.0, 120.0))
    elif name == "laser_tilt":
        drawn["azimuth_deg"] = float(rng.uniform(0, 360))
    elif name == "joint_offset":
        drawn["joint"] = str(rig.joint_names[int(rng.integers(0, 5))])
        drawn["temperature"] = str(rng.choice(links))
        drawn["sign"] = float(rng.choice([-1.0, 1.0]))
    elif name == "nonlinear_alpha":
        drawn["sign"] = float(rng.choice([-1.0, 1.0]))
    else:
        raise ValueError(f"not a SPEC §6 effect: {name!r}")
    return Truth(name, start, drawn)
