"""Recordings the command-line tests share, each made once per session (per xdist worker): a
file's tests are spread over the files of the commands they exercise, and a module-scoped
recording would be simulated again for every one of them.

- ``d``: three 6-hour runs at 30/75/10 % in one file, a joint whose zero drifts with link 3
  (SPEC §6 ``joint_offset``, 12.8 µrad/K) that the nominal model leaves out (issue #17); its
  replicate is the same protocol with another seed (new noise, same physics).
- ``data``: a short simulated recording, its tables, the same cut short, and bad inputs beside
  them (issue #13).
- ``two_runs``: two one-hour runs in one recording, its tables and diagnosis, and the same
  protocol recorded again with other noise, its tables under the same name (issue #46)."""

from __future__ import annotations

from pathlib import Path

import pytest
import thermrs

from tests.support.cli import cli, ok
from tests.support.scenarios import FAST_NODES
from tests.support.scenarios import THREE_RUNS_JOINT_OFFSET as SCENARIO

#: Three 10-minute runs at 30 % (one visit per camera a minute, 2 frames each).
SHORT = (
    """format = "thermrs-scenario/1"
seed = 3
[[run]]
name = "warm"
speed_pct = 30
duration_min = 20
cycle_s = 60
start = "ambient"
"""
    + FAST_NODES
)


@pytest.fixture(scope="session")
def data(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """A simulated recording, its extracted tables, the same recording cut short and the
    tables extracted from the cut one; a folder; a rig; a scenario."""
    d = tmp_path_factory.mktemp("cli-errors")
    sc = d / "short.toml"
    sc.write_text(SHORT)
    rig = thermrs.default_rig_path()
    rec = thermrs.simulate.simulate(rig, sc, d / "rec.mcap").recording
    thermrs.extract(rec, rig).write(d / "rec.parquet")
    cut = d / "cut.mcap"
    cut.write_bytes(rec.read_bytes()[: rec.stat().st_size * 2 // 3])
    ex = thermrs.extract(cut, rig)
    assert ex.report.data_loss  # the truth this test builds on: cutting loses data
    ex.write(d / "cut.parquet")
    (d / "folder").mkdir()
    bad_json = d / "bad.json"
    bad_json.write_text("{not json")
    bad_sc = d / "bad.toml"
    bad_sc.write_text(SHORT.replace("speed_pct = 30", "speed_pct = 130"))
    return {
        "dir": d,
        "rec": rec,
        "tables": d / "rec.parquet",
        "cut": cut,
        "cut_tables": d / "cut.parquet",
        "folder": d / "folder",
        "rig": rig,
        "sc": sc,
        "bad_sc": bad_sc,
        "bad_json": bad_json,
    }


@pytest.fixture(scope="session")
def d(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """The recording, its replicate, its extracted tables and its diagnosis (30 % → 75 %)."""
    root = tmp_path_factory.mktemp("second-hour")
    sc = root / "jo.toml"
    sc.write_text(SCENARIO)
    rig = thermrs.default_rig_path()
    rec, rep = root / "jo.mcap", root / "jo2.mcap"
    ok(cli("simulate", "--rig", str(rig), "--scenario", str(sc), "-o", str(rec)))
    ok(cli("simulate", "--rig", str(rig), "--scenario", str(sc), "-o", str(rep), "--seed", "18"))
    ok(cli("extract", str(rec), "--rig", str(rig), "-o", str(root / "jo.parquet"), "--quiet"))
    diag = root / "d.json"
    ok(
        cli("diagnose", "--rig", str(rig), "--train", f"{rec}#s30", "--holdout", f"{rec}#s75",
            "--json", str(diag))
    )  # fmt: skip
    return {"root": root, "rig": rig, "rec": rec, "rep": rep, "diag": diag, "sc": sc}


#: Two one-hour runs in one recording (run markers ``a`` and ``b``).
TWO_RUNS = (
    """format = "thermrs-scenario/1"
seed = 3
[[run]]
name = "a"
speed_pct = 30
duration_min = 60
cycle_s = 120
start = "ambient"
[[run]]
name = "b"
speed_pct = 75
duration_min = 60
cycle_s = 120
start = "continue"
idle_before_min = 30
"""
    + FAST_NODES
)


@pytest.fixture(scope="session")
def two_runs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """A recording's tables and diagnosis on the paper rig; the same protocol recorded again
    with other noise, its tables under the same name in another folder."""
    root = tmp_path_factory.mktemp("identity")
    rig = thermrs.default_rig_path()
    sc = root / "two.toml"
    sc.write_text(TWO_RUNS)
    (root / "other").mkdir()
    for rec, tables, seed in ((root / "rec.mcap", root / "rec.parquet", "3"),
                              (root / "o.mcap", root / "other" / "rec.parquet", "9")):  # fmt: skip
        ok(cli("simulate", "--rig", str(rig), "--scenario", str(sc), "-o", str(rec),
               "--seed", seed))  # fmt: skip
        ok(cli("extract", str(rec), "--rig", str(rig), "-o", str(tables), "--quiet"))
    diag = root / "diag.json"
    ok(cli("diagnose", "--rig", str(rig), "--train", f"{root / 'rec.parquet'}#a",
           "--holdout", f"{root / 'rec.parquet'}#b", "--json", str(diag)))  # fmt: skip
    return {"root": root, "rig": rig, "tables": root / "rec.parquet", "diag": diag,
            "other": root / "other" / "rec.parquet"}  # fmt: skip
