"""Campaigns of recordings thermrs did not write (issue #30): an independent writer's sample
without run markers, the same bytes under another name, copies made with the official
``mcap`` writer hours later and overlapping it in time, and one cut short
(:mod:`tests.support.foreign`), extracted through the CLI on the Dask ``LocalCluster``
thermrs starts: every recording in the catalog with the frames of its own single-file
extraction, and a second run extracting nothing. ``thermrs info`` on the same folder."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import polars as pl
import pytest
import thermrs
from polars.testing import assert_frame_equal

from tests.support.foreign import CUT_NAME, foreign_campaign, sample_path


@pytest.fixture(scope="module")
def recs(shared: Path, tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """The folder of :func:`tests.support.foreign.foreign_campaign`: name → recording."""
    return foreign_campaign(sample_path(shared), tmp_path_factory.mktemp("foreign") / "recs")


def _extract(*args: str) -> subprocess.CompletedProcess[str]:
    rig = str(thermrs.default_rig_path())
    return subprocess.run(
        [sys.executable, "-m", "thermrs", "extract", *args, "--rig", rig],
        capture_output=True,
        text=True,
        timeout=600,
    )


@pytest.mark.slow
def test_a_folder_of_foreign_recordings_is_a_campaign(
    recs: dict[str, Path], paper_rig: thermrs.Rig, tmp_path: Path
) -> None:
    folder = recs["sample"].parent
    out = tmp_path / "ds"
    p = _extract(str(folder), "-o", str(out))
    # Exit 3: every recording extracted, the cut one with its loss counted (SPEC §7).
    assert p.returncode == 3, p.stderr
    assert "Traceback" not in p.stderr and "internal error" not in p.stderr
    assert "Dask dashboard: http" in p.stderr  # the LocalCluster thermrs starts ran it
    assert f"{len(recs)} recordings extracted, 0 unchanged" in p.stderr
    loss_lines = [ln for ln in p.stderr.splitlines() if "data loss" in ln]
    assert len(loss_lines) == 1 and CUT_NAME in loss_lines[0], p.stderr

    ds = thermrs.campaigns.Dataset.open(out)
    cat = ds.catalog()
    assert sorted(cat["path"].to_list()) == sorted(str(r.resolve()) for r in recs.values())
    assert cat["recording"].is_unique().all()
    frames = ds.scan("frames").collect()
    runs = ds.scan("runs").collect()
    for name, path in recs.items():
        row = cat.filter(pl.col("path") == str(path.resolve())).row(0, named=True)
        ex = thermrs.extract(path, paper_rig)
        assert ex.report.data_loss == (name == "cut") == (row["losses"] > 0), name
        assert (row["frames"], row["visits"], row["runs"]) == (
            ex.frames.height,
            ex.visits.height,
            ex.runs.height,
        ), name
        mine = frames.filter(pl.col("recording") == row["recording"])
        got = mine.drop("recording", "run").select(ex.frames.columns).sort("camera", "t_ns")
        assert_frame_equal(got, ex.frames.sort("camera", "t_ns"))
        # No run markers: runs found from idle gaps, every frame inside one.
        assert mine["run"].null_count() == 0, name
        assert set(runs.filter(pl.col("recording") == row["recording"])["source"]) == {"gap"}
    # The copies are later in time, the overlapping one inside the sample's span.
    span = {n: cat.filter(pl.col("path") == str(p.resolve())).row(0, named=True)
            for n, p in recs.items()}  # fmt: skip
    assert span["later"]["start_ns"] - span["sample"]["start_ns"] == 6 * 3600 * 10**9
    assert span["sample"]["start_ns"] < span["overlap"]["start_ns"] < span["sample"]["end_ns"]

    # Run again: nothing extracted again, the same catalog; still exit 3 (the cut file).
    again = _extract(str(folder), "-o", str(out))
    assert again.returncode == 3, again.stderr
    assert f"0 recordings extracted, {len(recs)} unchanged" in again.stderr
    assert_frame_equal(thermrs.campaigns.Dataset.open(out).catalog(), cat)


def _info(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "thermrs", "info", *args], capture_output=True, text=True
    )


@pytest.mark.slow
@pytest.mark.floors
def test_info_takes_folders_and_globs_as_extract_does(recs: dict[str, Path]) -> None:
    """``thermrs info FOLDER`` and ``'GLOB'``: every recording below, each once, named as
    found; exit 3 for the cut one; the table says how it counts visits (not as extract)."""
    folder = recs["sample"].parent
    by_folder = _info(str(folder), "--json")
    assert by_folder.returncode == 3, by_folder.stderr
    docs = json.loads(by_folder.stdout)
    assert sorted(d["path"] for d in docs) == sorted(str(p) for p in recs.values())
    assert [d["losses"] != [] for d in docs] == [Path(d["path"]).name == CUT_NAME for d in docs]
    pattern = str(folder / "*.mcap")
    by_glob = _info(pattern, str(recs["sample"]), "--json")  # the sample named twice: once
    assert by_glob.returncode == 3 and json.loads(by_glob.stdout) == docs
    table = _info(str(recs["sample"]))
    assert table.returncode == 0, table.stderr
    assert "no message decoded" in table.stdout and "every sensor_msgs/msg/Image" in table.stdout
    with_rig = _info(str(recs["sample"]), "--rig", str(thermrs.default_rig_path()))
    assert (
        "no message decoded" in with_rig.stdout
        and "sensor_msgs/msg/Image" not in (with_rig.stdout.split("Runs:")[-1])
    )
    p = _info(str(folder / "zz*.mcap"))
    assert p.returncode == 2 and p.stderr.splitlines() == [
        f"thermrs: error: recordings {str(folder / 'zz*.mcap')!r}: the pattern matches no file"
    ], p.stderr
