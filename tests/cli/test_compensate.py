"""`thermrs compensate`: the law a diagnosis exports (CSV or JSON), applied by hand as a
controller would (Σ c·(T − T_ref)) to a run the diagnosis never saw, removes the share of the
error the diagnosis promised (issue #17)."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import polars as pl
import pytest
import thermrs

from tests.support.cli import cli, ok


def _run_temperatures(rec: Path, run: str) -> pl.DataFrame:
    (t,) = thermrs.runs.load_runs(f"{rec}#{run}", thermrs.load_rig()).tables
    return t.sort("camera", "t_ns")


@pytest.mark.slow
def test_the_compensation_law_applied_by_hand_removes_what_the_diagnosis_promised(
    d: dict[str, Path],
) -> None:
    diag = json.loads(d["diag"].read_text())
    promised = 1 - diag["verdict"]["holdout_rms_um"] / diag["baseline"]["holdout_rms_um"]
    law_csv, law_json = d["root"] / "comp.csv", d["root"] / "comp.json"
    for law_path in (law_csv, law_json):
        ok(cli("compensate", "--rig", str(d["rig"]), "--diagnosis", str(d["diag"]),
               "-o", str(law_path)))  # fmt: skip
    law = pl.read_csv(law_csv)
    doc = json.loads(law_json.read_text())
    assert doc["linearity_um"] < 0.1 and doc["reference_c"] == 23.0
    # The CSV alone is the law: one row per pose and axis, the reference temperature in it,
    # a µm/K column per temperature name, each with its interval.
    slopes = [
        c for c in law.columns if c.endswith("_um_per_k") and c != "chip_mount_ambient_um_per_k"
    ]
    assert slopes and (law["reference_c"] == 23.0).all()
    for c in slopes:
        assert (law[f"{c}_ci95_low"] <= law[c]).all() and (law[c] <= law[f"{c}_ci95_high"]).all()
    # A controller's arithmetic on the replicate's measured temperatures: Σ c·(T − T_ref).
    t = _run_temperatures(d["rep"], "s75")
    before, after = [], []
    for cam in ("A", "B"):
        g = t.filter(pl.col("camera") == cam)
        for axis in "uv":
            (row,) = law.filter((pl.col("camera") == cam) & (pl.col("axis") == axis)).to_dicts()
            pred = np.zeros(g.height)
            for c in slopes:
                name = c.removesuffix("_um_per_k")
                pred += (row[c] or 0.0) * (g[f"{name}_c"].to_numpy() - row["reference_c"])
            meas = g[f"{axis}_um"].to_numpy()
            # The nominal model: the diagnosis' baseline α, no effect.
            nominal = (
                thermrs.predict.predict(
                    g, thermrs.load_rig(), alpha_per_k=diag["baseline"]["alpha_per_k"]["value"]
                )
                .sort("t_ns")[f"predicted_{axis}_um"]
                .to_numpy()
            )
            for res, p in ((before, nominal), (after, pred)):
                r = meas - p
                res.append(r - r.mean())
    rms_before = math.sqrt(np.mean(np.concatenate(before) ** 2))
    rms_after = math.sqrt(np.mean(np.concatenate(after) ** 2))
    assert 1 - rms_after / rms_before == pytest.approx(promised, abs=0.05)


def test_check_takes_several_runs_as_documented(two_runs: dict[str, Path], tmp_path: Path) -> None:
    """README: `[--check RUN…]`: `--check A B` is `--check A --check B` (issue #46, M1)."""
    t, r, dg = str(two_runs["tables"]), str(two_runs["rig"]), str(two_runs["diag"])
    docs: list[dict[str, Any]] = []
    for form in ([f"{t}#a", f"{t}#b"], [f"{t}#a", "--check", f"{t}#b"]):
        out = tmp_path / f"law{len(docs)}.json"
        ok(cli("compensate", "--rig", r, "--diagnosis", dg, "-o", str(out), "--check", *form))
        docs.append(json.loads(out.read_text())["check"])
    assert [row["run"] for row in docs[0]["runs"]] == ["rec#a", "rec#b"]
    assert docs[0] == docs[1]
