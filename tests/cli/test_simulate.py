"""`thermrs simulate` on the command line: a scenario without thermal nodes on a rig whose
ROIs the default nodes do not name says what to add (issue #17). The simulator itself:
tests/model/test_simulate.py."""

from __future__ import annotations

from pathlib import Path

from tests.support.cli import bad, cli
from tests.support.rigs import UR5


def test_a_scenario_without_nodes_on_another_rig_says_so(tmp_path: Path) -> None:
    sc = tmp_path / "plain.toml"
    sc.write_text(
        'format = "thermrs-scenario/1"\nseed = 1\n[[run]]\nname = "a"\nspeed_pct = 30\n'
        'duration_min = 10\ncycle_s = 60\nstart = "ambient"\n'
    )
    msg = bad(cli("simulate", "--rig", str(UR5), "--scenario", str(sc), "-o",
                  str(tmp_path / "x.mcap")), "no [[node]]", "upper_arm")  # fmt: skip
    assert "add one [[node]] per ROI" in msg
