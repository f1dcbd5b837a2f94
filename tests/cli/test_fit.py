"""`thermrs fit` on the command line: the runs of one file are the library's runs (issue #17);
kelvin, radians and a copy of the training run refused with their reason (issue #17, through
`fit`, `rig` and `diagnose`); runs of one stem keep distinct keys (issue #13). The estimator
itself: tests/test_fit.py."""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import polars as pl
import pytest
import thermrs

from tests.support.cli import bad, cli, ok


@pytest.mark.slow
def test_the_library_fit_over_a_files_runs_is_the_cli_fit(d: dict[str, Path]) -> None:
    out = d["root"] / "fit.json"
    ok(cli("fit", "--rig", str(d["rig"]), "--train", str(d["rec"]), "--json", str(out)))
    rig = thermrs.load_rig()
    tables = thermrs.runs.load_runs(d["rec"], rig).tables
    assert len(tables) == 3
    f = thermrs.fit.fit_alpha(tables, rig)
    assert f.alpha_per_k == pytest.approx(json.loads(out.read_text())["alpha_per_k"]["value"])
    # One table across the runs would anchor all at the first run's start: refused.
    with pytest.raises(thermrs.InputError, match="holds 3 runs"):
        thermrs.fit.run_table(thermrs.extract(d["rec"], rig), rig)


@pytest.mark.slow
def test_kelvin_radians_and_a_copy_of_the_training_run_are_refused(
    d: dict[str, Path], tmp_path: Path
) -> None:
    rig = str(d["rig"])
    # Ambient written in kelvin.
    for part in ("", ".visits", ".joints", ".runs"):
        (tmp_path / f"k{part}.parquet").write_bytes((d["root"] / f"jo{part}.parquet").read_bytes())
    temps = pl.read_parquet(d["root"] / "jo.temperatures.parquet")
    kelvin = [c for c in ("temperature_c", "peak_c") if c in temps.columns]
    temps.with_columns(
        [
            pl.when(pl.col("name") == "ambient").then(pl.col(c) + 273.15).otherwise(pl.col(c))
            for c in kelvin
        ]
    ).write_parquet(tmp_path / "k.temperatures.parquet")
    bad(cli("fit", "--rig", rig, "--train", str(tmp_path / "k.parquet")), "ambient", "kelvin")
    # A rig whose poses are written in radians.
    text = Path(rig).read_text()
    doc = thermrs.load_rig().to_dict()
    for pose in doc["pose"]:
        block = "\n".join(f"    {v}," for v in pose["joints_deg"])
        text = re.sub(
            re.escape(block), "\n".join(f"    {math.radians(v):.6f}," for v in pose["joints_deg"]),
            text,
        )  # fmt: skip
    radrig = tmp_path / "radians.toml"
    radrig.write_text(text)
    assert all(
        all(abs(q) <= 2 * math.pi for q in p.joints_deg)
        for p in thermrs.load_rig(radrig).poses.values()
    )
    bad(cli("fit", "--rig", str(radrig), "--train", f"{d['rec']}#s30"), "radians")
    bad(cli("rig", str(radrig)), "misses", "radians")
    # A byte-identical copy of the training recording given as the held-out run.
    copy = tmp_path / "copy.mcap"
    copy.write_bytes(d["rec"].read_bytes())
    bad(cli("diagnose", "--rig", rig, "--train", f"{d['rec']}#s30", "--holdout", f"{copy}#s30"),
        "identical to training run")  # fmt: skip


def test_runs_of_one_stem_keep_distinct_keys(data: dict[str, Path], tmp_path: Path) -> None:
    out = tmp_path / "fit.json"
    p = cli("fit", "--rig", str(data["rig"]), "--train", str(data["tables"]), str(data["rec"]),
            "--json", str(out))  # fmt: skip
    assert p.returncode == 0, p.stderr
    assert sorted(json.loads(out.read_text())["start_end"]) == sorted(
        [str(data["tables"]), str(data["rec"])]
    )
