"""`thermrs design` as the user meets it: the files it writes, the words it prints (issue #46,
M9)."""

from __future__ import annotations

import json
from pathlib import Path

from tests.support.cli import cli, ok


def test_between_is_said_as_asked_and_no_candidate_files_without_a_recommendation(
    two_runs: dict[str, Path], tmp_path: Path
) -> None:
    """The diagnosis of these runs told the effects apart (`none`): asked to separate two of
    them, design does not call them confounded; and a candidate that no proof passed (here
    none was run) is no measurement to make: only design.json is written."""
    t, r = str(two_runs["tables"]), str(two_runs["rig"])
    diag = json.loads(two_runs["diag"].read_text())
    assert diag["verdict"]["status"] != "ambiguous" and not diag["confounded"]
    out = tmp_path / "d"
    p = ok(cli("design", "--rig", r, "--train", f"{t}#a", "--holdout", f"{t}#b",
               "--diagnosis", str(two_runs["diag"]), "--between", "thermal_lag", "sensor_drift",
               "--no-proof", "-o", str(out)))  # fmt: skip
    assert "asked to separate thermal_lag and sensor_drift" in p.stdout, p.stdout
    assert "confounded" not in p.stdout.split("\n", 1)[0]
    assert sorted(f.name for f in out.iterdir()) == ["design.json"]
    doc = json.loads((out / "design.json").read_text())
    assert doc["recommended"] is None and doc["files"] == {} and doc["candidates"]
    assert doc["between"] == ["thermal_lag", "sensor_drift"]
