"""The forward selection's revision (``thermrs.diagnose.selection._revision``) against a
simulated truth: a recorded random rig whose one effect leaves, once found, a gap the library
cannot explain (the runs' thermal camera reads fast-warming links; their simulator-truth
temperatures leave none). Chosen by the held-out runs among hundreds of pairs, a pair of wrong
effects fitted that gap best and was stated as `identified`; with each held-out run judging a
choice made without it, the revision keeps the truth, and the verdict says a gap is left. And
what the revision is for, on the independent world (:mod:`thermrs.bench.world`): two
effects at once, whose first step takes a family that mimics a part of both."""

from __future__ import annotations

from pathlib import Path

import pytest
import thermrs
from thermrs.bench.world.cases import Campaign
from thermrs.bench.world.score import outcome
from thermrs.diagnose import diagnose

from tests.support.pairs import run_pair
from tests.support.random_demo import TRUTH, random_demo_runs


@pytest.mark.slow
def test_a_gap_left_by_the_truth_is_not_filled_by_a_pair_chosen_on_the_held_out_runs(
    tmp_path: Path,
) -> None:
    rig, runs = random_demo_runs(tmp_path, 7)
    d = diagnose(runs[:1], runs[1:], rig)
    joint, temperature, urad = TRUTH
    first = d.selected[0]
    assert (first["effect"], first["params"].get("joint"), first["params"].get("temperature")) == (
        "joint_offset",
        joint,
        temperature,
    )
    assert first["params"]["urad_per_k"] == pytest.approx(urad, rel=0.15)
    # What is left is still a gap (above the floor, slow): never `identified` with anything
    # but the truth named.
    named = {s["effect"] for s in d.selected}
    assert d.verdict["status"] != "identified" or named == {"joint_offset"}


@pytest.mark.slow
def test_two_effects_whose_first_step_takes_a_mimic_are_both_named() -> None:
    # A joint offset and a drifting chip (SNR 2 each, white nuisances, 15-h runs) whose first
    # step takes the other chip's drift; the joint offset may come with its look-alikes (the
    # paper rig's joint-2/3 axes), named among the confounded effects.
    row = run_pair(
        ("joint_offset", "sensor_drift"),
        rig_path=str(thermrs.rig.default_rig_path()),
        snr=2.0,
        seed=4029,
        campaign=Campaign(hours=15.0),
    )
    assert outcome(row) == "right", row
