"""`thermrs report` on runs inside a recording (issue #17): `FILE#RUN`, the extracted tables of
a file with several runs, an output folder that does not exist; the overview figure with runs
side by side, each on its own hours. The report itself: tests/report/test_report.py."""

from __future__ import annotations

from pathlib import Path

import polars as pl
import pytest
import thermrs

from tests.support.cli import bad, cli, ok


@pytest.mark.slow
def test_report_takes_runs_inside_a_recording(d: dict[str, Path], tmp_path: Path) -> None:
    rig = str(d["rig"])
    one = tmp_path / "one.html"
    ok(cli("report", "--rig", rig, "--run", f"{d['rec']}#s30", "--run", f"{d['rec']}#s75",
           "-o", str(one), "--quiet", "--no-markdown"))  # fmt: skip
    html = one.read_text()
    assert "jo#s30" in html and "jo#s75" in html and "jo#s10" not in html
    # The diagnosed model used: the held-out run predicted with α and the identified effect.
    assert "predicted with α and the identified effect" in html
    # The extracted tables of the whole file: its three runs, not one merged 22-hour run.
    allr = tmp_path / "all.html"
    p = ok(cli("report", "--rig", rig, "--run", str(d["root"] / "jo.parquet"), "-o", str(allr),
               "--quiet", "--no-markdown"))  # fmt: skip
    assert "3 runs (run markers): s30 " in p.stderr
    assert "using jo#s30, jo#s75, jo#s10" in p.stderr
    html = allr.read_text()
    assert all(f"jo#{r}" in html for r in ("s30", "s75", "s10"))
    # -o into a folder that does not exist: an error, nothing created.
    bad(cli("report", "--rig", rig, "--run", f"{d['rec']}#s30", "-o",
            str(tmp_path / "missing" / "r.html")), "does not exist")  # fmt: skip
    assert not (tmp_path / "missing").exists()


@pytest.mark.slow
def test_the_overview_puts_runs_side_by_side(d: dict[str, Path]) -> None:
    from thermrs.report import figures

    rig = thermrs.load_rig()
    tables = thermrs.runs.load_runs(d["rec"], rig).tables
    # Two of them on one clock as if recorded on other days: the same times.
    shifted = tables[1].with_columns(t_ns=pl.col("t_ns") - tables[1]["t_ns"].min())
    svg = figures.fig_overview(
        [("a", tables[0]), ("b", shifted), ("c", tables[2])],
        {"A": "#1f77b4", "B": "#d62728"},
        ["link2", "link3"],
        {"link2": "#2ca02c", "link3": "#9467bd"},
    )
    # A panel per run and row, each run's own hours from 0.
    assert svg.count('id="axes_') == 6
