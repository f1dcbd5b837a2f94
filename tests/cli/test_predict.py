"""`thermrs predict` on the command line: with a diagnosis (`--diagnosis`) on a run the
diagnosis never saw, the share of the error it promised removed (issue #17); with a diagnosis
that found nothing, the nominal model; `--alpha` in the units people write and `--series` in
the format its name says (issue #13)."""

from __future__ import annotations

import json
from pathlib import Path

import polars as pl
import pytest

from tests.support.cli import bad, cli, ok


@pytest.mark.slow
def test_predict_with_the_diagnosis_shrinks_a_run_it_never_saw_by_the_promised_share(
    d: dict[str, Path],
) -> None:
    diag = json.loads(d["diag"].read_text())
    assert diag["verdict"]["status"] == "identified", diag["summary"]
    assert diag["verdict"]["effect"] == "joint_offset"
    promised = 1 - diag["verdict"]["holdout_rms_um"] / diag["baseline"]["holdout_rms_um"]
    assert promised > 0.5
    out = d["root"] / "p.json"
    p = ok(cli("predict", "--rig", str(d["rig"]), "--diagnosis", str(d["diag"]),
               "--run", f"{d['rep']}#s75", "--json", str(out)))  # fmt: skip
    assert "before" in p.stdout and "after" in p.stdout
    doc = json.loads(out.read_text())
    (everything,) = [r for r in doc["table"] if r["run"] == "all"]
    assert everything["shrink"] == pytest.approx(promised, abs=0.05)
    # What is left is the measurement's noise, not the model: the nominal model's gap was
    # several times it.
    assert everything["nominal_rms_um"] > 3 * everything["diagnosed_rms_um"]


@pytest.mark.slow
def test_a_diagnosis_that_found_nothing_predicts_with_the_nominal_model(
    d: dict[str, Path], tmp_path: Path
) -> None:
    doc = json.loads(d["diag"].read_text())
    doc["verdict"] = {**doc["verdict"], "status": "none", "effect": None, "params": {}}
    none = tmp_path / "none.json"
    none.write_text(json.dumps(doc))
    out = tmp_path / "p.json"
    p = ok(cli("predict", "--rig", str(d["rig"]), "--diagnosis", str(none),
               "--run", f"{d['rep']}#s75", "--json", str(out)))  # fmt: skip
    assert "nominal model is used" in p.stderr
    (everything,) = [r for r in json.loads(out.read_text())["table"] if r["run"] == "all"]
    assert everything["shrink"] == pytest.approx(0.0, abs=1e-12)
    bad(cli("compensate", "--rig", str(d["rig"]), "--diagnosis", str(d["rec"]), "-o",
            str(tmp_path / "c.csv")), "--diagnosis", "not a `thermrs diagnose --json`")  # fmt: skip
    bad(cli("compensate", "--rig", str(d["rig"]), "--diagnosis", str(d["diag"]), "-o",
            str(tmp_path / "c.txt")), "-o", ".csv or .json")  # fmt: skip


@pytest.mark.slow
@pytest.mark.floors
def test_alpha_takes_units_and_series_writes_the_format_named(
    data: dict[str, Path], tmp_path: Path
) -> None:
    docs = {}
    for alpha in ("23.2e-6", "23.2u", "23.2µ", "2.32e-05"):
        out = tmp_path / f"p{len(docs)}.json"
        p = cli("predict", "--rig", str(data["rig"]), "--alpha", alpha, "--run",
                str(data["tables"]), "--json", str(out))  # fmt: skip
        assert p.returncode == 0, p.stderr
        docs[alpha] = json.loads(out.read_text())["alpha_per_k"]["given"]
    assert all(v == pytest.approx(23.2e-6, rel=1e-12) for v in docs.values()), docs
    csv, parquet = tmp_path / "s.csv", tmp_path / "s.parquet"
    for path in (csv, parquet):
        p = cli("predict", "--rig", str(data["rig"]), "--alpha", "2.2e-5", "--run",
                str(data["tables"]), "--series", str(path))  # fmt: skip
        assert p.returncode == 0, p.stderr
    a, b = pl.read_csv(csv), pl.read_parquet(parquet)
    assert a.columns == b.columns and a.height == b.height > 0
    assert not csv.read_bytes().startswith(b"PAR1")
