"""The demo's runs, cut from its one recording at the scenario's schedule, against the
simulator's own record of every CCD frame (``demo.truth.parquet``, which extraction never
reads): no visit is lost at a cut (issue #46: run 2's first visit of camera A, one frame
stamped at run 2's exact start, fell 123 ns before the cut when visit times went through
float64)."""

from __future__ import annotations

from pathlib import Path

import polars as pl
import pytest

pytestmark = pytest.mark.slow


def test_every_truth_frame_is_a_visit_of_its_run(tmp_path: Path) -> None:
    from thermrs.report.demo import simulate_demo

    d = simulate_demo(tmp_path)
    truth = pl.read_parquet(tmp_path / "demo.truth.parquet")
    # One frame per visit in the demo: each true frame is one visit, its stamp the visit's.
    for r in d.runs:
        got = r.table.select("camera", "t_ns").sort("camera", "t_ns")
        want = truth.filter(pl.col("run") == r.name).select("camera", "t_ns").sort("camera", "t_ns")
        assert got.equals(want), r.name
