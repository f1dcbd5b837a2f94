"""The demo's scenario on a random KR 16-like rig: the paper's three 15-h runs (30/75/10 %,
300 s cycles) with one effect the nominal model leaves out, joint 3's zero drifting by
12.8 µrad per kelvin of link 3 (SPEC §6 ``joint_offset``), the links' ROIs simulated with the
calibrated fast nodes (:data:`tests.support.scenarios.FAST_NODES`). Recorded with images, so
the runs carry everything a recording does (centroid noise, the thermal camera's reading)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import polars as pl
import thermrs
import tomli_w
from thermrs.analyses.demo import demo_scenario_path
from thermrs.design.files import rig_dict
from thermrs.runs import load_runs

from tests.support.coverage import random_rig
from tests.support.scenarios import FAST_NODES

#: The effect the runs carry: ``(joint, temperature, µrad/K)``.
TRUTH = ("a3", "link3", 12.8)


def random_demo_runs(workdir: Path, seed: int) -> tuple[thermrs.Rig, list[pl.DataFrame]]:
    """``(rig, [run1, run2, run3])`` of the demo scenario on ``random_rig(seed)``; the rig,
    scenario and recording are written into ``workdir`` (the recording reused if there)."""
    rig = random_rig(np.random.default_rng(seed))
    workdir.mkdir(parents=True, exist_ok=True)
    rig_path = workdir / "rig.toml"
    rig_path.write_text(tomli_w.dumps(rig_dict(rig, None)))
    sc = demo_scenario_path().read_text()
    sc = sc[: sc.index("\n[[effect]]")] + "\n"
    sc += FAST_NODES[: FAST_NODES.index('[[node]]\nname = "base"')]
    joint, temperature, urad = TRUTH
    sc += f'\n[[effect]]\nname = "joint_offset"\njoint = "{joint}"\n'
    sc += f'temperature = "{temperature}"\nurad_per_k = {urad}\n'
    sc_path = workdir / "scenario.toml"
    sc_path.write_text(sc)
    rig = thermrs.Rig.from_path(rig_path)
    rec = workdir / "random.mcap"
    if not rec.exists():
        thermrs.simulate.simulate(rig, sc_path, rec)
    cache: dict[object, object] = {}
    return rig, [
        load_runs(f"{rec}#{k}", rig, cache=cache).tables[0] for k in ("run1", "run2", "run3")
    ]
