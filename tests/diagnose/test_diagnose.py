"""The diagnoser against injected truth: runs made by the bench's own generator (its own
thermal law, lag filter and chip closed forms, perturbed by what the diagnoser does not model),
an effect injected that the diagnoser is not told."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import polars as pl
import pytest
import thermrs
from thermrs.bench import make_runs
from thermrs.diagnose import diagnose
from thermrs.effects import SensorDrift, ThermalLag

#: Simulations and campaigns of minutes: skipped by `pytest -m "not slow"`.
pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def rig() -> thermrs.Rig:
    return thermrs.load_rig()


@pytest.fixture(scope="module")
def lag_runs(rig: thermrs.Rig) -> list[pl.DataFrame]:
    return make_runs(rig, ThermalLag(tau_min=70.0), seed=7, hours=6.0)


def test_an_injected_lag_is_identified_with_its_time_constant(
    rig: thermrs.Rig, lag_runs: list[pl.DataFrame]
) -> None:
    d = diagnose(lag_runs[:1], lag_runs[1:], rig, bootstrap=10)
    assert d.status == "identified", d.summary
    assert d.verdict["effect"] == "thermal_lag"
    assert abs(d.verdict["params"]["tau_min"] - 70.0) <= 0.25 * 70.0
    hf = d.how_far
    assert hf["holdout_rms_after_um"] < hf["holdout_rms_before_um"]
    assert hf["gap_closed"] >= 0.7
    doc = d.to_json()
    # SPEC §7 keys.
    assert {"train_rms_um", "holdout_rms_um"} <= set(doc["baseline"])
    assert {"run", "camera", "axis", "phase", "rms_um", "share"} <= set(doc["location"][0])
    assert abs(sum(r["share"] for r in doc["location"]) - 1.0) < 1e-9
    assert {"effect", "params", "holdout_rms_um", "shrink", "evidence"} <= set(doc["ranking"][0])
    assert doc["ranking"][0]["effect"] == "thermal_lag"
    r0 = doc["ranking"][0]
    assert (
        abs(r0["shrink"] - (1 - r0["holdout_rms_um"] / doc["baseline"]["holdout_rms_um"])) < 1e-12
    )
    assert {"status", "effect", "params", "confounded_with", "holdout_rms_um"} <= set(
        doc["verdict"]
    )
    json.dumps(doc)  # serialisable
    # The residual table the report draws: every visit and axis, before and after.
    assert d.residuals.height == 2 * sum(t.height for t in lag_runs)
    assert d.residuals["after_um"].null_count() == 0


def test_the_lag_withheld_is_not_blamed_on_another_effect(
    rig: thermrs.Rig, lag_runs: list[pl.DataFrame]
) -> None:
    d = diagnose(lag_runs[:1], lag_runs[1:], rig, bootstrap=0, exclude=["thermal_lag"])
    assert d.status in ("unexplained", "ambiguous", "partially explained"), d.summary
    assert "thermal_lag" not in [r["effect"] for r in d.ranking]


def test_no_effect_gives_none(rig: thermrs.Rig) -> None:
    runs = make_runs(rig, None, seed=11, hours=6.0)
    d = diagnose(runs[:1], runs[1:], rig, bootstrap=0)
    assert d.status == "none", d.summary
    assert d.verdict["effect"] is None


def test_a_chip_that_drifts_on_its_own_is_found_on_its_camera(rig: thermrs.Rig) -> None:
    truth = SensorDrift(camera="B", tau_min=50.0, um=(-10.0, 8.0))
    runs = make_runs(rig, truth, seed=12, hours=6.0)
    d = diagnose(runs[:1], runs[1:], rig, bootstrap=0)
    assert d.verdict["effect"] == "sensor_drift", d.summary
    p = d.verdict["params"]
    assert p["camera"] == "B"
    assert np.allclose(p["um"], truth.um, atol=0.25 * 10.0)


def test_noise_floor_matches_a_known_white_noise(rig: thermrs.Rig) -> None:
    # Without the perturbations, the visits carry white noise only: the floor is what the
    # nominal model leaves on the held-out runs.
    runs = make_runs(rig, None, seed=13, hours=6.0, perturb=False)
    d = diagnose(runs[:1], runs[1:], rig, bootstrap=0)
    assert d.noise_floor_um == pytest.approx(d.how_far["holdout_rms_before_um"], rel=0.1)


@pytest.mark.parametrize(
    ("train", "holdout", "exclude", "message"),
    [
        (1, 0, (), "no held-out run"),
        (0, 1, (), "no training run"),
        (1, 1, ("gremlins",), "not effects"),
    ],
)
def test_bad_input_is_one_clear_error(
    rig: thermrs.Rig,
    lag_runs: list[pl.DataFrame],
    train: int,
    holdout: int,
    exclude: tuple[str, ...],
    message: str,
) -> None:
    with pytest.raises(thermrs.InputError, match=message):
        diagnose(lag_runs[:train], lag_runs[1 : 1 + holdout], rig, exclude=exclude)


def test_runs_without_visits_and_repeated_names_are_errors(
    rig: thermrs.Rig, lag_runs: list[pl.DataFrame]
) -> None:
    empty = lag_runs[1].with_columns(pl.lit(float("nan")).alias("u_um"))
    with pytest.raises(thermrs.InputError, match="no visits"):
        diagnose(lag_runs[:1], [empty], rig)
    with pytest.raises(thermrs.InputError, match="distinct"):
        diagnose(lag_runs[:1], lag_runs[:1], rig)


def _as_extracted(table: pl.DataFrame, out: Path) -> Path:
    """Write a run table as the Parquet set `thermrs extract` writes (visits, temperatures)."""
    visits = table.select("camera", "visit", "t_ns", "u_um", "v_um", "drift_u_um", "drift_v_um")
    visits = visits.with_columns(pl.lit(4).alias("n_ok"))
    temps = []
    for name in ("link2", "link3", "ambient"):
        t = table.select("t_ns", pl.lit(name).alias("name"), pl.col(f"{name}_c").alias("peak_c"))
        temps.append(t.with_columns(pl.col("peak_c").alias("temperature_c")))
    stem = str(table["run"][0])
    visits.write_parquet(out / f"{stem}.visits.parquet")
    pl.concat(temps).sort("t_ns").write_parquet(out / f"{stem}.temperatures.parquet")
    return out / f"{stem}.visits.parquet"


def test_cli_diagnoses_extracted_tables_with_spec_json(
    rig: thermrs.Rig, lag_runs: list[pl.DataFrame], tmp_path: Path
) -> None:
    paths = [_as_extracted(t, tmp_path) for t in lag_runs]
    out = tmp_path / "d.json"
    cmd = [sys.executable, "-m", "thermrs", "diagnose", "--rig", str(thermrs.default_rig_path())]
    cmd += ["--train", str(paths[0]), "--holdout", str(paths[1]), str(paths[2])]
    cmd += ["--bootstrap", "5", "--json", str(out)]
    p = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    assert p.returncode == 0, p.stderr
    doc = json.loads(out.read_text())
    assert doc["verdict"]["status"] == "identified"
    assert doc["verdict"]["effect"] == "thermal_lag"
    assert "Verdict: identified" in p.stdout
    # No held-out run: exit 2, one line.
    bad = subprocess.run(cmd[:8], capture_output=True, text=True, timeout=600)
    assert bad.returncode == 2
    assert len(bad.stderr.strip().splitlines()) == 1, bad.stderr


def test_the_papers_gap_is_diagnosed_from_table_4() -> None:
    from thermrs.diagnose.paper import paper_diagnosis

    d = paper_diagnosis()
    # Table 4's six numbers, as printed.
    assert list(d["measured_um"].values()) == [131.0, 130.0, 120.0, 120.0, -40.0, -41.0]
    # SPEC/issue: the forward model at the handbook α gives about half of the measured drift.
    ratio = np.array(list(d["nominal"]["predicted_v_um"].values())) / np.array(
        list(d["measured_um"].values())
    )
    assert np.all((ratio > 0.4) & (ratio < 0.6))
    assert 40e-6 < d["nominal"]["alpha_to_fit_alone_per_k"] < 50e-6
    assert d["explains"], d["summary"]
    for c in d["candidates"]:
        if c["family"] in d["explains"]:
            assert c["plausible"] and c["rms_um"] <= 5.0
    names = {c["effect"] for c in d["cannot_act"]}
    assert {"thermal_lag", "sensor_drift"} <= names
    p = subprocess.run(
        [sys.executable, "-m", "thermrs", "diagnose", "--paper"],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert p.returncode == 0, p.stderr
    assert "Table 4" in p.stdout
