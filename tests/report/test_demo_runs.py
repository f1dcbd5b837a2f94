"""The demo report against the world it was made from: the simulator's own record of every CCD
frame (``demo.truth.parquet``, which extraction never reads) and the commands run on the
recording it keeps (``--workdir``).

- No visit is lost at a cut (issue #46: run 2's first visit of camera A, one frame stamped at
  run 2's exact start, fell 123 ns before the cut when visit times went through float64).
- The summary's end errors are given along each chip axis, each the one `thermrs predict
  --axis` gives on the kept recording; Table 6 names the chip axis of each α; the ISO 9283
  section says how long its windows last, as the simulator's schedule does.
"""

from __future__ import annotations

import json
import re
from typing import Any

import polars as pl
import pytest
import thermrs

from tests.support.cli import cli, ok

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def demo(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    d = tmp_path_factory.mktemp("demo-world")
    ok(cli("report", "--demo", "--workdir", str(d / "work"), "-o", str(d / "demo.html")))
    return {"work": d / "work", "md": (d / "demo.md").read_text(), "dir": d}


def test_every_truth_frame_is_a_visit_of_its_run(demo: dict[str, Any]) -> None:
    from thermrs.analyses.demo import simulate_demo

    d = simulate_demo(demo["work"], reuse=True)
    truth = pl.read_parquet(demo["work"] / "demo.truth.parquet")
    # One frame per visit in the demo: each true frame is one visit, its stamp the visit's.
    for r in d.runs:
        got = r.table.select("camera", "t_ns").sort("camera", "t_ns")
        want = truth.filter(pl.col("run") == r.name).select("camera", "t_ns").sort("camera", "t_ns")
        assert got.equals(want), r.name


def _predict(demo: dict[str, Any], axis: str) -> list[dict[str, Any]]:
    rig = str(thermrs.default_rig_path())
    tables = demo["dir"] / "demo.parquet"
    if not tables.exists():
        ok(cli("extract", str(demo["work"] / "demo.mcap"), "--rig", rig, "-o", str(tables),
               "--quiet"))  # fmt: skip
    out = demo["dir"] / f"predict-{axis}.json"
    ok(cli("predict", "--rig", rig, "--train", f"{tables}#run1", "--run", f"{tables}#run2",
           f"{tables}#run3", "--axis", axis, "--json", str(out)))  # fmt: skip
    rows: list[dict[str, Any]] = json.loads(out.read_text())["table"]
    return rows


def test_the_summary_gives_the_end_error_along_each_axis_as_predict_does(
    demo: dict[str, Any],
) -> None:
    (sentence,) = [ln for ln in demo["md"].splitlines() if ln.startswith("With that α")]
    for axis, name in (("u", "x (u)"), ("v", "y (v)")):
        errs = [r["error_pct"] for r in _predict(demo, axis) if r["alpha"] == "series"]
        assert f"{min(errs):+.2f} to {max(errs):+.2f} % along the chip's {name} axis" in sentence
    # Table 4's drift of run 2 is predict's measured drift (the first visit kept: H3).
    v = {(r["camera"], r["run"]): r for r in _predict(demo, "v") if r["alpha"] == "series"}
    table4 = demo["md"][demo["md"].index("*Table 4-style") :]
    row = next(ln for ln in table4.splitlines() if ln.startswith("| run2 | "))
    assert row.split("|")[3].strip() == "360"  # visits: 180 per camera, as simulated
    assert f"| {v[('A', 'demo#run2')]['measured_um']:.2f} |" in row


def test_table6_names_the_chip_axis_of_each_alpha(demo: dict[str, Any]) -> None:
    rig = str(thermrs.default_rig_path())
    out = demo["dir"] / "fit.json"
    ok(cli("fit", "--rig", rig, "--train", f"{demo['work'] / 'demo.mcap'}#run1", "--json",
           str(out)))  # fmt: skip
    (se,) = json.loads(out.read_text())["start_end"].values()
    rows = [ln for ln in demo["md"].splitlines() if ln.startswith("| start/end | run1 |")]
    got = {ln.split("|")[3].strip(): ln.split("|")[4].strip() for ln in rows}
    assert {c: got[c] for c in se["per_camera"]} == {
        c: v["axis"] for c, v in se["per_camera"].items()
    }
    assert "| time-series | run1 | all | u and v |" in demo["md"]


def test_the_iso_section_says_its_windows_as_the_schedule_has_them(demo: dict[str, Any]) -> None:
    """Ten visits per window: camera A's first ten frames of run 1 in the simulator's truth."""
    truth = pl.read_parquet(demo["work"] / "demo.truth.parquet")
    t = truth.filter((pl.col("run") == "run1") & (pl.col("camera") == "A")).sort("t_ns")["t_ns"]
    minutes = round((t[9] - t[0]) / 60e9)
    (para,) = [ln for ln in demo["md"].splitlines() if "Windows of 10 consecutive visits" in ln]
    assert f"({minutes} min here)" in para and "warm-up drift inside its window" in para
    row = next(ln for ln in demo["md"].splitlines() if ln.startswith("| run1 | A |"))
    assert re.search(rf"\| 0–{minutes} \|", row), row


def test_the_diagnosis_is_the_one_diagnose_makes_on_the_kept_recording(
    demo: dict[str, Any],
) -> None:
    rig, rec = str(thermrs.default_rig_path()), demo["work"] / "demo.mcap"
    out = demo["dir"] / "diagnose.json"
    ok(cli("diagnose", "--rig", rig, "--train", f"{rec}#run1", "--holdout", f"{rec}#run2",
           f"{rec}#run3", "--json", str(out)))  # fmt: skip
    doc = json.loads(out.read_text())
    before = doc["baseline"]["holdout_rms_um"]
    assert f"leaves {before:.2f} µm rms on the held-out runs" in demo["md"]
    assert f"Verdict: {doc['verdict']['status']}" in demo["md"]


def test_the_intro_says_what_diagnose_paper_finds(demo: dict[str, Any]) -> None:
    """The demo's scenario is introduced with `thermrs diagnose --paper`'s numbers (L9)."""
    out = demo["dir"] / "paper.json"
    ok(cli("diagnose", "--paper", "--json", str(out)))
    doc = json.loads(out.read_text())
    by = {c["family"]: c for c in doc["candidates"]}
    jo = by["joint_offset joint=joint_a3 temperature=link3"]
    p = {k: round(v) for k, v in jo["predicted_v_um"].items()}
    said = (
        f"{p['run1/A']}/{p['run1/B']}, {p['run2/A']}/{p['run2/B']} and "
        f"−{-p['run3/A']}/−{-p['run3/B']} µm"
    )
    assert said in demo["md"] and f"rms {jo['rms_um']:.1f} µm" in demo["md"]
    (group,) = [g for g in doc["indistinguishable"] if jo["family"] in g]
    words = {5: "five", 6: "six", 7: "seven", 8: "eight"}
    assert f"cannot tell it from {words[len(group) - 1]} other effects" in demo["md"]
    best = min((by[f] for f in group), key=lambda c: c["rms_um"])
    where = best["params"].get("temperature", best["params"].get("roi"))
    assert where == "link3" and f"rms {best['rms_um']:.1f} µm" in demo["md"]
