"""A second, independent world for ``diagnose-bench``: its own rig reader, kinematics, ray–plane
geometry, thermal physics, effects, instruments and visit errors, used only to make bench
cases (issue 16). It shares no code with :mod:`thermrs.model`, :mod:`thermrs.signatures`,
:mod:`thermrs.effects` or the Rust core, so the diagnoser is never scored on runs made by its
own forward model.
"""

from __future__ import annotations

from thermrs.bench.world.geometry import WorldRig, laser_spots, read_rig
from thermrs.bench.world.snr import Sizer
from thermrs.bench.world.truth import EFFECTS, Truth, draw_truth
from thermrs.bench.world.world import WORLDS, Campaign, Scene, draw_scene, render

__all__ = [
    "EFFECTS",
    "WORLDS",
    "Campaign",
    "Scene",
    "Sizer",
    "Truth",
    "WorldRig",
    "draw_scene",
    "draw_truth",
    "laser_spots",
    "read_rig",
    "render",
]
