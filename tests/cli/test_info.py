"""`thermrs info`: what a recording holds (issue #17): every topic's messages against the mcap
package's own reader, the runs its markers give with their visits, frames per camera, what each
ROI drives; on a recording cut short, the loss and the runs written so far; on an independent
writer's recording without run markers, one run split by idle gaps."""

from __future__ import annotations

import json
import tomllib
from pathlib import Path

import pytest
from mcap.reader import make_reader

from tests.support.cli import cli, ok
from tests.support.scenarios import THREE_RUNS_JOINT_OFFSET as SCENARIO
from tests.support.scenarios import THREE_RUNS_VISITS as VISITS


@pytest.mark.slow
def test_info_says_what_the_recording_holds(d: dict[str, Path]) -> None:
    doc = json.loads(ok(cli("info", str(d["rec"]), "--rig", str(d["rig"]), "--json")).stdout)[0]
    # Every topic's count against the mcap package reading every message.
    counts: dict[str, int] = {}
    with open(d["rec"], "rb") as f:
        for _, ch, _ in make_reader(f).iter_messages():
            counts[ch.topic] = counts.get(ch.topic, 0) + 1
    assert {t["topic"]: t["messages"] for t in doc["topics"]} == counts
    roles = {t["topic"]: t["role"] for t in doc["topics"]}
    assert roles["/ccd_a/image_raw"].startswith("camera A")
    assert roles["/thermal/image_raw"] == "thermal camera"
    # The runs the scenario wrote, with one visit per camera and cycle each.
    runs = tomllib.loads(SCENARIO)["run"]
    assert [r["run"] for r in doc["runs"]] == [r["name"] for r in runs]
    assert all(r["source"] == "marker" for r in doc["runs"])
    for r, s in zip(doc["runs"], runs, strict=True):
        assert (r["end_ns"] - r["start_ns"]) / 60e9 == pytest.approx(s["duration_min"], abs=0.01)
        assert r["visits"] == 2 * VISITS
    frames = {c["camera"]: c["frames"] for c in doc["cameras"]}
    assert frames == {"A": 3 * VISITS, "B": 3 * VISITS}
    drives = {r["roi"]: r["drives"] for r in doc["rois"]}
    assert drives == {"link2": "a2", "link3": "d4", "base": ""}
    assert doc["losses"] == [] and doc["from_summary"]
    # ~15.7 h from the first to the last message: 3 × 6 h and a 4-hour idle.
    assert doc["duration_s"] / 3600 == pytest.approx(22.0, abs=0.1)


@pytest.mark.slow
def test_info_on_a_cut_recording_and_one_without_markers(
    d: dict[str, Path], shared: Path, tmp_path: Path
) -> None:
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(d["rec"].read_bytes()[: d["rec"].stat().st_size // 2])
    p = cli("info", str(cut), "--rig", str(d["rig"]), "--json")
    assert p.returncode == 3, p.stderr
    assert "data loss" in p.stderr and str(cut) in p.stderr
    doc = json.loads(p.stdout)[0]
    assert not doc["from_summary"] and doc["losses"]
    # The marker written so far, and the visits after it split by idle gaps.
    assert [r["run"] for r in doc["runs"]] == ["s30", "unmarked1"]
    # An independent writer's recording without run markers: one run, split by gaps.
    sample = shared / "samples" / "kr15-sample.mcap"
    doc = json.loads(ok(cli("info", str(sample), "--json")).stdout)[0]
    with open(sample, "rb") as f:
        n = sum(1 for _ in make_reader(f).iter_messages())
    assert doc["messages"] == n
    assert [r["source"] for r in doc["runs"]] == ["gap"]
