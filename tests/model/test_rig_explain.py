"""What a rig explains (SPEC §7 ``thermrs rig``): ``Rig.explain`` on a laser that misses its
camera (no spot there, the problem listed); the tables for the embedded rig and its ``--json``,
whose flange positions, spots and incidences are the paper's."""

from __future__ import annotations

import json
import math

import pytest
import thermrs

from tests.support.rig_mutations import (
    MISSES,
    SHARED_RIG,
    SOURCE,
    dumps_toml,
    good_doc,
    requires_shared,
    run_rig_cli,
)

# --------------------------------------------------------------------------------------------
# A laser that misses its pose's camera: the file parses, ``explain`` says what it misses
# --------------------------------------------------------------------------------------------


def test_rotated_laser_stays_unit_and_parses() -> None:
    doc = good_doc()
    MISSES(doc)
    assert math.hypot(*doc["laser"]["direction"]) == pytest.approx(1.0, abs=1e-12)
    rig = thermrs.Rig.from_toml(dumps_toml(doc), source_name=SOURCE)
    view = rig.explain()
    assert view["poses"]["A"]["spot_px"]["A"] is None
    assert view["problems"]


# --------------------------------------------------------------------------------------------
# Good rigs: the CLI
# --------------------------------------------------------------------------------------------


def test_cli_rig_without_argument_explains_the_embedded_rig() -> None:
    result = run_rig_cli()
    assert result.returncode == 0, result.stderr
    assert result.stderr == ""
    assert "Pose A" in result.stdout and "Pose B" in result.stdout


@pytest.mark.parametrize(
    "args",
    [
        pytest.param([], id="embedded-no-argument"),
        pytest.param([str(thermrs.default_rig_path())], id="embedded-path"),
        pytest.param([str(SHARED_RIG)], id="shared", marks=requires_shared),
    ],
)
def test_cli_rig_json_matches_the_paper(args: list[str]) -> None:
    result = run_rig_cli(*args, "--json")
    assert result.returncode == 0, result.stderr
    doc = json.loads(result.stdout)
    poses = doc["poses"]
    assert set(poses) == {"A", "B"}
    for pose, want in {"A": (1087.78, -48.62, 217.75), "B": (1087.33, -38.29, 198.07)}.items():
        got = poses[pose]["flange_mm"]
        assert len(got) == 3
        assert all(abs(g - w) < 0.1 for g, w in zip(got, want, strict=True)), (pose, got)
    a = poses["A"]
    assert a["spot_px"]["A"] == pytest.approx([375.5, 290.5], abs=1e-6)
    assert a["spot_px"]["B"] is None
    assert abs(a["incidence_deg"]["A"]) < 1e-4
    assert poses["B"]["spot_px"]["B"] is not None
