"""The forward selection's revision (``thermrs.diagnose.selection._revision``) against a
simulated truth: a recorded random rig whose one effect leaves, once found, a gap the library
cannot explain (the runs' thermal camera reads fast-warming links; their simulator-truth
temperatures leave none). Chosen by the held-out runs among hundreds of pairs, a pair of wrong
effects fitted that gap best and was stated as `identified`; chosen on the training runs and
judged on the held-out runs, the revision keeps the truth, and the verdict says a gap is left."""

from __future__ import annotations

from pathlib import Path

import pytest
from thermrs.diagnose import diagnose

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
