"""The commands' tables: whole when piped (no cell cut, a row a line), folded at 80 columns
in a narrow terminal (issue #13); numbers shown only where they mean something: an end error
inside the noise compared in µm, not in %, and a heating curve whose τ is not determined
said so (issue #17)."""

from __future__ import annotations

import json
import math
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import thermrs

from tests.support.cli import cli, ok


@pytest.mark.slow
def test_diagnose_tables_are_whole_when_piped(d: dict[str, Path]) -> None:
    for args in (
        ["diagnose", "--paper"],
        ["diagnose", "--rig", str(d["rig"]), "--train", f"{d['rec']}#s30",
         "--holdout", f"{d['rec']}#s75"],
    ):  # fmt: skip
        p = ok(cli(*args))
        assert "…" not in p.stdout, p.stdout
        # Piped, a row is one line: no line is a wrapped cell's continuation.
        assert max(len(ln) for ln in p.stdout.splitlines()) > 80


CONTROL = """format = "thermrs-scenario/1"
name = "a control: slow, short, no effect"
seed = 23
[[run]]
name = "idle"
speed_pct = 10
duration_min = 40
cycle_s = 120
start = "ambient"
[ambient]
start_c = 23.0
noise_c = 0.02
"""


@pytest.mark.slow
def test_end_errors_inside_the_noise_and_undetermined_heating_curves_are_said_so(
    tmp_path: Path,
) -> None:
    rig = str(thermrs.default_rig_path())
    sc = tmp_path / "ctl.toml"
    sc.write_text(CONTROL)
    rec = tmp_path / "ctl.mcap"
    ok(cli("simulate", "--rig", rig, "--scenario", str(sc), "-o", str(rec)))
    js = tmp_path / "p.json"
    p = ok(cli("predict", "--rig", rig, "--alpha", "23.2u", "--run", str(rec), "--json", str(js)))
    table = json.loads(js.read_text())["table"]
    rows = [ln for ln in p.stdout.splitlines() if ln.startswith("│")]
    assert len(rows) == len(table)
    quiet = 0
    for row, ln in zip(table, rows, strict=True):
        pair = 2 * math.sqrt(2) * row["noise_um"]
        inside = abs(row["measured_um"]) <= pair
        quiet += inside
        # A drift inside the noise: compared in µm, no % of a drift that is not there; "within
        # noise" only where the prediction's error is inside it too.
        error_inside = abs(row["predicted_um"] - row["measured_um"]) <= pair
        assert ("within noise" in ln) == (inside and error_inside), ln
        assert ("too small for a %" in ln) == (inside and not error_inside), ln
        if inside:
            assert f"{row['error_pct']:+.2f}" not in ln
    assert quiet >= 1  # the control's slow 40 minutes move the spot less than its noise
    dj = tmp_path / "d.json"
    p = ok(cli("drift", "--rig", rig, "--run", str(rec), "--json", str(dj)))
    curves = json.loads(dj.read_text())["curves"]

    def determined(c: dict[str, float | None]) -> bool:
        tau, se = c["tau_min"], c["tau_min_se"]
        return tau is not None and se is not None and tau > 0 and se <= tau / 2

    loose = [c for c in curves if c["phase"] and not determined(c)]
    assert loose, "the control should leave some τ undetermined"
    assert p.stdout.count("no heating curve: τ not determined") == len(loose)


def test_tables_fold_at_80_columns_and_are_whole_when_piped(data: dict[str, Path]) -> None:
    # A run name longer than a narrow terminal leaves room for.
    long_run = data["dir"] / "a-rather-long-run-name-from-the-night-shift.parquet"
    for part in ("", ".visits", ".temperatures", ".joints"):
        src = data["dir"] / f"rec{part}.parquet"
        shutil.copy(src, data["dir"] / f"a-rather-long-run-name-from-the-night-shift{part}.parquet")
    try:
        args = ["predict", "--rig", str(data["rig"]), "--alpha", "2.2e-5", "--run", str(long_run)]
        env = {**os.environ, "COLUMNS": "80"}
        narrow = subprocess.run(
            [sys.executable, "-m", "thermrs", *args], capture_output=True, text=True, env=env
        )
        piped = cli(*args)
    finally:
        for part in ("", ".visits", ".temperatures", ".joints"):
            (data["dir"] / f"a-rather-long-run-name-from-the-night-shift{part}.parquet").unlink()
    headers = ["pred µm", "meas µm", "err %", "rms µm", "noise µm"]
    for p in (narrow, piped):
        assert p.returncode == 0, p.stderr
        assert "…" not in p.stdout, p.stdout
        for h in headers:
            for word in h.split():
                assert word in p.stdout, (word, p.stdout)
    assert max(len(ln) for ln in narrow.stdout.splitlines()) <= 80, narrow.stdout
    # Piped: every row on one line, the run name whole.
    assert "a-rather-long-run-name-from-the-night-shift" in piped.stdout
    assert any(all(h in ln for h in headers) for ln in piped.stdout.splitlines()), piped.stdout
    # Narrow: the name is folded onto lines, not cut: all of its characters are there.
    run_cells = "".join(
        ln.split("│")[3].strip() for ln in narrow.stdout.splitlines() if ln.startswith("│")
    )
    assert "a-rather-long-run-name-from-the-night-shift" in run_cells, narrow.stdout
