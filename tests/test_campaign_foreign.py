"""Campaigns of recordings thermrs did not write (issue #30): an independent writer's sample
without run markers, the same bytes under another name, copies made with the official
``mcap`` writer hours later and overlapping it in time, and one cut short
(:mod:`tests.support.foreign`), extracted through the CLI on the Dask ``LocalCluster``
thermrs starts: every recording in the catalog with the frames of its own single-file
extraction, and a second run extracting nothing."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import polars as pl
import pytest
import thermrs
from polars.testing import assert_frame_equal

from tests.support.foreign import CUT_NAME, foreign_campaign, sample_path


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
    shared: Path, paper_rig: thermrs.Rig, tmp_path: Path
) -> None:
    recs = foreign_campaign(sample_path(shared), tmp_path / "recs")
    out = tmp_path / "ds"
    p = _extract(str(tmp_path / "recs"), "-o", str(out))
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
    again = _extract(str(tmp_path / "recs"), "-o", str(out))
    assert again.returncode == 3, again.stderr
    assert f"0 recordings extracted, {len(recs)} unchanged" in again.stderr
    assert_frame_equal(thermrs.campaigns.Dataset.open(out).catalog(), cat)
