"""Every input knows what it belongs to (issue #46): extracted tables carry the rig they were
extracted with, a diagnosis its runs' content and its rig, a law its rig. Tables, a diagnosis
or a law analysed with another rig's cameras or ROIs, and a diagnosis of other recordings
that carry the same run names, are refused in one line (exit 2) and nothing is written.

The world the checks stand on: the rig files as written (read with ``tomllib``), the tables'
Parquet metadata as ``pyarrow`` reads it, another robot's rig (the UR5 fixture, placed with
the Robotics Toolbox) and a second recording of the same protocol with other noise."""

from __future__ import annotations

import json
import subprocess
import tomllib
from pathlib import Path
from typing import Any

import polars as pl
import pyarrow.parquet as pq  # type: ignore[import-untyped]
import pytest
import thermrs
import tomli_w

from tests.support.cli import cli, ok
from tests.support.rigs import UR5


def rig_file(path: Path, edit: Any, text_before: str = "") -> Path:
    """A copy of the paper rig, its data changed by ``edit`` (written with ``tomli_w``)."""
    data = tomllib.loads(thermrs.default_rig_path().read_text())
    edit(data)
    path.write_text(text_before + tomli_w.dumps(data))
    return path


def test_tables_carry_the_rig_they_were_extracted_with(two_runs: dict[str, Path]) -> None:
    rig = tomllib.loads(Path(two_runs["rig"]).read_text())
    stem = two_runs["tables"].with_suffix("")
    for part in ("", ".visits", ".temperatures", ".joints", ".runs"):
        meta = pq.read_metadata(f"{stem}{part}.parquet").metadata
        ident = json.loads(meta[b"thermrs.rig"])
        cams = [(c["name"], c["topic"]) for c in ident["map"]["cameras"]]
        assert cams == [(c["name"], c["topic"]) for c in rig["camera"]]
        rois = [(r["name"], r["rect_px"]) for r in ident["map"]["thermal"]["rois"]]
        assert rois == [(r["name"], r["rect_px"]) for r in rig["thermal"]["roi"]]
        poses = {p["name"]: p["joints_deg"] for p in rig["pose"]}
        for c, want in zip(ident["map"]["cameras"], rig["camera"], strict=True):
            assert c["pose_joints_deg"] == poses[want["pose"]]
    # The digest a campaign catalog keeps for the same rig file.
    from thermrs.campaigns.engine import rig_identity

    assert ident["digest"] == rig_identity(two_runs["rig"])[2]


def commands(two_runs: dict[str, Path], rig: Path, out: Path) -> dict[str, list[str]]:
    t, r, dg = str(two_runs["tables"]), str(rig), str(two_runs["diag"])
    return {
        "fit": ["fit", "--rig", r, "--train", f"{t}#a", "--json", str(out)],
        "predict": ["predict", "--rig", r, "--alpha", "23.2u", "--run", f"{t}#b", "--json",
                    str(out)],
        "drift": ["drift", "--rig", r, "--run", t, "--json", str(out)],
        "diagnose": ["diagnose", "--rig", r, "--train", f"{t}#a", "--holdout", f"{t}#b",
                     "--json", str(out)],
        "report": ["report", "--rig", r, "--run", t, "-o", str(out)],
        "compensate": ["compensate", "--rig", r, "--diagnosis", dg, "-o", str(out)],
        "predict --diagnosis": ["predict", "--rig", r, "--diagnosis", dg, "--run", f"{t}#b",
                                "--json", str(out)],
    }  # fmt: skip


def error_line(p: subprocess.CompletedProcess[str]) -> str:
    """The one error line of a refused command (a report's progress lines aside)."""
    assert p.returncode == 2, (p.returncode, p.stderr)
    lines = [ln for ln in p.stderr.splitlines() if ln.startswith("thermrs: error")]
    assert len(lines) == 1 and "Traceback" not in p.stderr and "Warning" not in p.stderr, p.stderr
    return lines[0]


@pytest.mark.parametrize(
    "command",
    ["fit", "predict", "drift", "diagnose", "report", "compensate", "predict --diagnosis"],
)
def test_another_robots_rig_is_refused_and_nothing_written(
    two_runs: dict[str, Path], tmp_path: Path, command: str
) -> None:
    """The UR5's cameras are ``near`` and ``far``; the tables and the diagnosis are of the KR
    15's A and B."""
    out = tmp_path / ("out.html" if command == "report" else "out.json")
    line = error_line(cli(*commands(two_runs, UR5, out)[command]))
    assert "cameras A, B, where the rig has near, far" in line, line
    assert not out.exists() and list(tmp_path.iterdir()) == []


def test_another_roi_is_refused_and_comments_tolerances_lengths_and_a_new_chip_are_not(
    two_runs: dict[str, Path], tmp_path: Path
) -> None:
    def roi(d: dict[str, Any]) -> None:
        d["thermal"]["roi"][0]["rect_px"] = [44, 60, 120, 110]

    def topic(d: dict[str, Any]) -> None:
        d["camera"][1]["topic"] = "/ccd_c/image_raw"

    def remeasured(d: dict[str, Any]) -> None:
        d["robot"]["dh"][1]["a_mm"] += 0.3
        d["tolerances"] = {"length_mm": 0.5, "chip_mm": 0.5}

    t = f"{two_runs['tables']}#a"
    line = error_line(cli("fit", "--rig", str(rig_file(tmp_path / "r1.toml", roi)), "--train", t))
    assert "ROI link2 at [40, 60, 120, 110], where the rig has it at [44, 60, 120, 110]" in line
    line = error_line(cli("fit", "--rig", str(rig_file(tmp_path / "r2.toml", topic)), "--train", t))
    assert "camera B's topic /ccd_b/image_raw, where the rig has /ccd_c/image_raw" in line
    same = rig_file(tmp_path / "r3.toml", remeasured, "# the same rig, re-measured\n")
    ok(cli("fit", "--rig", str(same), "--train", t))

    def grown(d: dict[str, Any]) -> None:  # a new chip beside the old ones, as design adds
        d["camera"].append({**d["camera"][1], "name": "C", "topic": "/ccd_c/image_raw"})

    ok(cli("fit", "--rig", str(rig_file(tmp_path / "r4.toml", grown)), "--train", t))


def test_tables_written_before_they_carried_their_rig_are_checked_by_their_names(
    two_runs: dict[str, Path], tmp_path: Path
) -> None:
    stem = two_runs["tables"].with_suffix("")
    for part in ("", ".visits", ".temperatures", ".joints", ".runs"):
        pl.read_parquet(f"{stem}{part}.parquet").write_parquet(tmp_path / f"old{part}.parquet")
    assert b"thermrs.rig" not in (pq.read_metadata(tmp_path / "old.visits.parquet").metadata)
    line = error_line(cli("fit", "--rig", str(UR5), "--train", f"{tmp_path / 'old.parquet'}#a"))
    assert "cameras A, B, where the rig has near, far" in line
    ok(cli("fit", "--rig", str(two_runs["rig"]), "--train", f"{tmp_path / 'old.parquet'}#a"))


def test_a_diagnosis_of_other_recordings_with_the_same_run_names_is_refused(
    two_runs: dict[str, Path], tmp_path: Path
) -> None:
    """The other recording's tables are ``rec.parquet`` too: its runs are named ``rec#a`` and
    ``rec#b`` like the diagnosed ones, and hold other data. Predicting them with the diagnosed
    model is what the model is for."""
    o, r, dg = str(two_runs["other"]), str(two_runs["rig"]), str(two_runs["diag"])
    out = tmp_path / "r.html"
    line = error_line(cli("report", "--rig", r, "--train", f"{o}#a", "--run", f"{o}#b",
                          "--diagnosis", dg, "-o", str(out)))  # fmt: skip
    assert "other data under the same run names (rec#a, rec#b" in line
    line = error_line(cli("design", "--rig", r, "--train", f"{o}#a", "--holdout", f"{o}#b",
                          "--diagnosis", dg, "-o", str(tmp_path / "d")))  # fmt: skip
    assert "other data under the same run names" in line
    assert list(tmp_path.iterdir()) == []
    ok(cli("predict", "--rig", r, "--diagnosis", dg, "--run", f"{o}#b"))
    # The diagnosed recording itself is accepted.
    t = str(two_runs["tables"])
    ok(cli("design", "--rig", r, "--train", f"{t}#a", "--holdout", f"{t}#b", "--diagnosis", dg,
           "-o", str(tmp_path / "d")))  # fmt: skip


def test_a_diagnosis_written_before_it_carried_digests_is_accepted_with_a_warning(
    two_runs: dict[str, Path], tmp_path: Path
) -> None:
    doc = json.loads(two_runs["diag"].read_text())
    assert set(doc["run_digests"]) == {"rec#a", "rec#b"} and doc["rig"]["map"]["cameras"]
    del doc["run_digests"], doc["rig"]
    old = tmp_path / "old.json"
    old.write_text(json.dumps(doc))
    o, r = str(two_runs["other"]), str(two_runs["rig"])
    p = ok(cli("design", "--rig", r, "--train", f"{o}#a", "--holdout", f"{o}#b",
               "--diagnosis", str(old), "-o", str(tmp_path / "d")))  # fmt: skip
    warned = [ln for ln in p.stderr.splitlines() if ln.startswith("thermrs: warning")]
    assert len(warned) == 1 and "no digest of its runs" in warned[0], p.stderr
    # Its rig is still checked, by the cameras its residuals name.
    line = error_line(cli("compensate", "--rig", str(UR5), "--diagnosis", str(old),
                          "-o", str(tmp_path / "x.csv")))  # fmt: skip
    assert "cameras A, B, where the rig has near, far" in line


def test_the_law_carries_its_rig(two_runs: dict[str, Path], tmp_path: Path) -> None:
    law = tmp_path / "law.json"
    ok(
        cli(
            "compensate",
            "--rig",
            str(two_runs["rig"]),
            "--diagnosis",
            str(two_runs["diag"]),
            "-o",
            str(law),
        )
    )
    rig = tomllib.loads(Path(two_runs["rig"]).read_text())
    doc = json.loads(law.read_text())
    assert [c["name"] for c in doc["rig"]["map"]["cameras"]] == [c["name"] for c in rig["camera"]]
    assert doc["rig"]["model"] == rig["robot"]["model"]
