"""Prediction against known truth: exact on model data, at the noise level on a held-out
simulated run, the paper's Eq. 3 beside it, and the `thermrs predict` / `thermrs fit` CLI."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import polars as pl
import pytest
import thermrs
from thermrs import ForwardModel, paper
from thermrs.fit import fit_alpha, load_run_table, run_table
from thermrs.predict import noise_um, predict, prediction_table
from thermrs.simulate import simulate

#: Simulations and campaigns of minutes: skipped by `pytest -m "not slow"`.
pytestmark = pytest.mark.slow

SCENARIO = """format = "thermrs-scenario/1"
seed = {seed}
[[run]]
name = "{name}"
speed_pct = {speed}
duration_min = 180
cycle_s = 120
start = "ambient"
"""


@pytest.fixture(scope="module")
def runs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """A training run at 75 % and a held-out run at 40 % (different seeds), no effect."""
    d = tmp_path_factory.mktemp("runs")
    rig = thermrs.load_rig()
    out = {}
    for name, speed, seed in (("train", 75, 11), ("holdout", 40, 12)):
        sc = d / f"{name}.toml"
        sc.write_text(SCENARIO.format(seed=seed, name=name, speed=speed))
        out[name] = simulate(rig, sc, d / f"{name}.mcap").recording
    return out


def model_table(rig: thermrs.Rig, alpha: float) -> pl.DataFrame:
    """Visits whose spots come from the forward model at ``alpha`` (offsets per camera)."""
    m = ForwardModel(rig, alpha_per_k=alpha)
    rows = []
    for k in range(20):
        t2 = 23.4 + 5 * (1 - np.exp(-k * 30 / 392))
        t3 = 23.35 + 7 * (1 - np.exp(-k * 30 / 308))
        for cam, off in (("A", (3.0, -5.0)), ("B", (-40.0, 12.0))):
            s = m.spots(
                cam, rig.camera_pose(cam).joints_rad, temperatures={"link2": t2, "link3": t3}
            )
            rows.append(
                {
                    "run": "r",
                    "camera": cam,
                    "visit": k,
                    "t_ns": k * 10**9,
                    "u_um": float(s.u_um[0]) + off[0],
                    "v_um": float(s.v_um[0]) + off[1],
                    "link2_c": t2,
                    "link3_c": t3,
                }
            )
    return pl.DataFrame(rows)


def test_exact_on_model_data(paper_rig: thermrs.Rig) -> None:
    """At the α that made the spots, every residual vanishes; the drift is anchored at the
    first visit; Eq. 3 matches the paper module's own prediction."""
    table = model_table(paper_rig, 23.2e-6)
    p = predict(table, paper_rig, alpha_per_k=23.2e-6)
    assert p.height == table.height
    assert np.max(np.abs(p[["residual_u_um", "residual_v_um"]].to_numpy())) < 1e-9
    first = p.filter(pl.col("visit") == 0)
    assert np.all(first[["measured_u_um", "predicted_u_um", "paper_v_um"]].to_numpy() == 0)
    last = p.filter((pl.col("visit") == 19) & (pl.col("camera") == "A"))
    t = table.filter((pl.col("visit") == 19) & (pl.col("camera") == "A"))
    dt2 = t["link2_c"].item() - 23.4
    dt3 = t["link3_c"].item() - 23.35
    assert last["paper_v_um"].item() == pytest.approx(
        paper.predicted_dl_um(23.2e-6, "A", dt2, dt3), rel=1e-12
    )
    # A wrong α leaves a residual proportional to the drift.
    q = predict(table, paper_rig, alpha_per_k=23.2e-6 * 1.1)
    r = q.filter(pl.col("visit") == 19)
    assert np.allclose(r["residual_u_um"], -0.1 * r["predicted_u_um"] / 1.1, atol=1e-9)
    tab = prediction_table([table], paper_rig, alphas={"true": 23.2e-6, "high": 25.52e-6})
    assert tab.height == 4
    exact = tab.filter(pl.col("alpha") == "true")
    assert np.all(np.abs(exact["error_pct"].to_numpy()) < 1e-9)
    high = tab.filter(pl.col("alpha") == "high")
    assert np.allclose(high["error_pct"].to_numpy(), 10.0, atol=1e-6)


def test_noise_estimator_ignores_a_slow_drift() -> None:
    rng = np.random.default_rng(5)
    t = np.linspace(0, 1, 2000)
    y = 40 * (1 - np.exp(-t / 0.3)) + 1.7 * rng.standard_normal(t.size)
    assert noise_um(y) == pytest.approx(1.7, rel=0.05)
    assert np.isnan(noise_um(np.array([1.0, 2.0])))


@pytest.mark.parametrize("rho", [0.5, 0.8])
def test_noise_estimator_sees_autocorrelated_noise(rho: float) -> None:
    """Issue #9: AR(1) visit noise (marginal σ 1.7 µm) on a slow drift. The von Neumann
    estimator alone reads σ·√(1−ρ) (0.71σ, 0.45σ): a perfect model's residual would look
    like a failure against it. The estimator returns the marginal σ."""
    rng = np.random.default_rng(6)
    n = 4000
    e = np.empty(n)
    e[0] = rng.normal(0, 1.7)
    for k in range(1, n):
        e[k] = rho * e[k - 1] + rng.normal(0, 1.7 * np.sqrt(1 - rho**2))
    y = 40 * (1 - np.exp(-np.linspace(0, 1, n) / 0.3)) + e
    assert noise_um(y) == pytest.approx(1.7, rel=0.1)


def test_noise_estimator_removes_the_drift_step() -> None:
    """A drift whose step from visit to visit is as large as the noise (0.2 µm per visit,
    noise 0.12 µm, as in a 3-hour warm-up at one visit every 2 minutes): the raw von Neumann
    estimator reads the step as noise (0.18 µm); removing the mean step leaves 0.12."""
    rng = np.random.default_rng(7)
    t = np.arange(90.0)
    y = 0.2 * t + 0.12 * rng.standard_normal(t.size)
    assert np.sqrt(np.mean(np.diff(y) ** 2) / 2) > 0.16
    assert noise_um(y) == pytest.approx(0.12, rel=0.2)


def test_held_out_run_is_predicted_to_the_noise_level(
    runs: dict[str, Path], paper_rig: thermrs.Rig
) -> None:
    """α fitted on a 75 % run predicts a 40 % run (no effect): over every visit the
    prediction is within 1.5× the measurement's own visit-to-visit noise, per camera."""
    train = run_table(thermrs.extract(runs["train"], paper_rig), paper_rig, run="train")
    hold = run_table(thermrs.extract(runs["holdout"], paper_rig), paper_rig, run="holdout")
    f = fit_alpha([train], paper_rig)
    assert f.ci95[0] < 23.2e-6 < f.ci95[1]
    tab = prediction_table([hold], paper_rig, alphas={"fit": f.alpha_per_k})
    assert set(tab["camera"]) == {"A", "B"}
    for row in tab.iter_rows(named=True):
        assert row["rms_centred_um"] < 1.5 * row["noise_um"], row
        assert 0.5 < row["noise_um"] < 5.0, row
        # The drift is tens of µm along chip u at these poses.
        assert row["axis"] == "u" and abs(row["measured_um"]) > 10, row
    # With the simulator's own α the series agree as well; with α off by 30 % they do not.
    off = prediction_table([hold], paper_rig, alphas={"off": 1.3 * 23.2e-6})
    assert all(r["rms_centred_um"] > 1.5 * r["noise_um"] for r in off.iter_rows(named=True))


def run_cli(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "thermrs", *args], capture_output=True, text=True, check=False
    )


def test_cli_predict_and_fit_on_recordings_and_tables(
    runs: dict[str, Path], tmp_path: Path
) -> None:
    rig = str(thermrs.default_rig_path())
    # Extracted tables stand in for a recording anywhere a run is read.
    r = run_cli("extract", str(runs["holdout"]), "--rig", rig, "-o", str(tmp_path / "h.parquet"))
    assert r.returncode == 0, r.stderr
    fit_json = tmp_path / "fit.json"
    # SPEC §7 writes `--train REC…`: several values after one option.
    r = run_cli(
        "fit", "--rig", rig, "--train", str(runs["train"]), str(tmp_path / "h.visits.parquet"),
        "--json", str(fit_json),
    )  # fmt: skip
    assert r.returncode == 0, r.stderr
    doc = json.loads(fit_json.read_text())
    lo, hi = doc["alpha_per_k"]["ci95"]
    assert lo < 23.2e-6 < hi
    assert set(doc["start_end"]) == {"train", "h"}
    assert set(doc["start_end"]["train"]["per_camera"]) == {"A", "B"}

    out = tmp_path / "pred.json"
    series = tmp_path / "series.parquet"
    r = run_cli(
        "predict", "--rig", rig, "--train", str(runs["train"]), "--run",
        str(tmp_path / "h.parquet"), "--json", str(out), "--series", str(series),
    )  # fmt: skip
    assert r.returncode == 0, r.stderr
    assert "Predicted against measured" in r.stdout
    doc = json.loads(out.read_text())
    assert set(doc["alpha_per_k"]) == {"series", "A", "B", "mean"}
    rows = doc["table"]
    assert {(x["alpha"], x["camera"]) for x in rows} == {
        (a, c) for a in ("series", "A", "B", "mean") for c in ("A", "B")
    }
    for x in rows:
        assert {"predicted_um", "measured_um", "error_pct", "run"} <= set(x)
        assert x["run"] == "h"
    s = pl.read_parquet(series)
    assert s.height == 4 * load_run_table(tmp_path / "h.parquet", thermrs.load_rig())[0].height

    r = run_cli("predict", "--rig", rig, "--fit", str(fit_json), "--run", str(runs["holdout"]))
    assert r.returncode == 0, r.stderr


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--run", "X.mcap"], "give exactly one of --alpha, --fit, --diagnosis or --train"),
        (["--alpha", "2e-5", "--run", "nope.mcap"], "'nope.mcap' does not exist"),
        (["--fit", "nope.json", "--run", "X.mcap"], "'--fit': File 'nope.json' does not exist"),
    ],
)
def test_cli_predict_bad_input_is_one_line(args: list[str], message: str, tmp_path: Path) -> None:
    (tmp_path / "X.mcap").write_bytes(b"")  # inputs are checked to exist before anything else
    r = subprocess.run(
        [
            sys.executable,
            "-m",
            "thermrs",
            "predict",
            "--rig",
            str(thermrs.default_rig_path()),
            *args,
        ],
        capture_output=True,
        text=True,
        cwd=tmp_path,
    )
    assert r.returncode == 2
    assert r.stderr.count("\n") == 1 and message in r.stderr, r.stderr


def test_cli_bad_fit_file_and_usage_errors_are_one_line(tmp_path: Path) -> None:
    bad = tmp_path / "fit.json"
    bad.write_text('{"alpha": 1}')
    r = run_cli(
        "predict", "--rig", str(thermrs.default_rig_path()), "--fit", str(bad), "--run", str(bad)
    )
    assert r.returncode == 2 and r.stderr.count("\n") == 1
    assert "not a `thermrs fit --json` file" in r.stderr
    r = run_cli("fit", "--train", str(bad))
    assert r.returncode == 2 and r.stderr.count("\n") == 1
    assert "Missing option '--rig'" in r.stderr


def test_cli_drift_curves_and_iso9283(runs: dict[str, Path], tmp_path: Path) -> None:
    out = tmp_path / "drift.json"
    rig = str(thermrs.default_rig_path())
    r = run_cli("drift", "--rig", rig, "--run", str(runs["train"]), "--json", str(out))
    assert r.returncode == 0, r.stderr
    assert "Heating curves" in r.stdout and "ISO 9283-style" in r.stdout
    doc = json.loads(out.read_text())
    link3 = next(c for c in doc["curves"] if c["series"] == "link3")
    # The heat model's link-3 time constant is 308 min; 3 h of a warm-up pins it loosely.
    assert link3["phase"] == "warm-up" and 200 < link3["tau_min"] < 450
    cams = {row["camera"] for row in doc["iso9283"]["summary"]}
    assert cams == {"A", "B"}


def test_a_start_end_alpha_is_judged_along_the_axis_it_was_taken_along() -> None:
    # Issue 31: the start/end α names its chip axis, and Table 7 judges it on that axis.
    from thermrs.analyses.fit import fit_document, training_axes
    from thermrs.bench import make_runs

    rig = thermrs.load_rig()
    runs = make_runs(rig, None, seed=3, hours=4.0, perturb=False)
    doc = fit_document(runs[:1], rig)
    axes = training_axes(doc)
    per_camera = next(iter(doc.to_json()["start_end"].values()))["per_camera"]
    assert axes and {c: v["axis"] for c, v in per_camera.items()} == axes
    for cam, ax in axes.items():
        # The axis is the one along which the camera's first-to-last drift is larger.
        g = runs[0].filter(pl.col("camera") == cam).sort("t_ns")
        du = abs(g["u_um"][-1] - g["u_um"][0])
        dv = abs(g["v_um"][-1] - g["v_um"][0])
        assert ax == ("u" if du >= dv else "v") or abs(du - dv) < 5.0
    forced = {c: ("v" if a == "u" else "u") for c, a in axes.items()}
    t = prediction_table(runs[1:2], rig, alphas={"A": 2.3e-5}, camera_axes=forced)
    assert dict(zip(t["camera"], t["axis"], strict=True)) == forced
