"""The data-driven baselines (thermrs.analyses.baselines, issue 49) against truths they did not
produce: coefficients of a drift that is an exact linear function of the temperatures, the
held-out rms of a least-squares fit computed here with numpy alone, cross-validation folds
that never split a run, the low-pass filter's closed form, and the command's JSON."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import polars as pl
import pytest
import thermrs
from thermrs.analyses.baselines import (
    MODELS,
    compare_baselines,
    cv_folds,
    features,
    fit_baseline,
    lowpass,
)

from tests.support.cli import bad, cli, ok
from tests.support.scenarios import FAST_NODES

RIG = thermrs.load_rig(thermrs.default_rig_path())
TEMPS = ("link2", "link3", "base", "ambient")
#: The truth: µm of drift per kelvin of each temperature, per (camera, axis).
COEF = {
    ("A", "u"): (1.5, -0.8, 3.0, 0.4),
    ("A", "v"): (-2.0, 4.5, 0.0, -1.1),
    ("B", "u"): (0.7, 0.3, -2.5, 0.9),
    ("B", "v"): (3.3, -1.7, 1.2, 0.0),
}


def _run(name: str, *, speed: float, day: int, noise_um: float, rng: np.random.Generator,
         n: int = 60, cycle_s: float = 300.0) -> pl.DataFrame:  # fmt: skip
    """A run whose temperatures warm by first-order curves (time constants and rises set by
    ``speed``) and whose drift is exactly Σ COEF·ΔT, plus white noise."""
    parts = []
    for ci, cam in enumerate(("A", "B")):
        t = np.arange(n) * cycle_s + 30.0 * ci
        temps = {
            "link2": 22.0 + 6.0 * speed * (1 - np.exp(-t / 1800.0)),
            "link3": 22.5 + 8.0 * speed**1.5 * (1 - np.exp(-t / 3000.0)),
            "base": 22.2 + 2.0 * speed * (1 - np.exp(-t / 9000.0)) + 0.3 * np.sin(t / 5000.0),
            "ambient": 21.0 + 0.5 * np.sin(t / 7000.0 + day),
        }
        d = np.column_stack([temps[k] - temps[k][0] for k in TEMPS])
        cols = {}
        for ax in ("u", "v"):
            drift = d @ np.asarray(COEF[(cam, ax)])
            cols[f"{ax}_um"] = 100.0 * (ci + 1) + drift + rng.normal(0, noise_um, n)
        parts.append(
            pl.DataFrame(
                {
                    "run": [name] * n,
                    "camera": [cam] * n,
                    "t_ns": (1_750_000_000 + day * 86400 + t).astype(np.int64) * 10**9,
                    **cols,
                    **{f"{k}_c": v for k, v in temps.items()},
                }
            )
        )
    return pl.concat(parts)


def test_least_squares_recovers_the_coefficients_of_an_exactly_linear_drift() -> None:
    rng = np.random.default_rng(1)
    runs = [_run("a", speed=0.3, day=0, noise_um=0.0, rng=rng),
            _run("b", speed=0.75, day=1, noise_um=0.0, rng=rng)]  # fmt: skip
    f = features(runs, RIG, smooth=False)
    assert f.temperatures == sorted(TEMPS)
    fb = fit_baseline("ols", f, np.ones(f.visits.n, dtype=bool))
    for (cam, ax), truth in COEF.items():
        est = fb.estimators[(cam, ax)]
        got = dict(zip(f.temperatures, est.coef_, strict=True))
        np.testing.assert_allclose([got[k] for k in TEMPS], truth, atol=1e-8)
        assert abs(est.intercept_) < 1e-8
    # Least squares fits one coefficient per temperature per channel.
    assert fb.n_params == len(TEMPS) * len(COEF)


def test_held_out_rms_agrees_with_least_squares_computed_independently() -> None:
    rng = np.random.default_rng(7)
    train = [_run("a", speed=0.3, day=0, noise_um=1.0, rng=rng),
             _run("b", speed=0.75, day=1, noise_um=1.0, rng=rng)]  # fmt: skip
    hold = [_run("c", speed=0.5, day=2, noise_um=1.0, rng=rng),
            _run("d", speed=0.1, day=3, noise_um=1.0, rng=rng)]  # fmt: skip
    c = compare_baselines(train, hold, RIG, models=("ols", "lowpass_lasso"), draws=199,
                          smooth=False)  # fmt: skip
    # Independently: per camera and axis, [1, T − T(first visit)] → spot − spot(first visit)
    # by numpy's least squares on the training runs; each held-out (run, camera, axis)
    # residual centred; the rms over all of them.
    res: list[np.ndarray] = []
    per_run: dict[str, list[np.ndarray]] = {}

    def rel(t: pl.DataFrame, cam: str) -> tuple[np.ndarray, np.ndarray]:
        p = t.filter(pl.col("camera") == cam).sort("t_ns")
        x = np.column_stack([p[f"{k}_c"].to_numpy() for k in sorted(TEMPS)])
        y = np.column_stack([p["u_um"].to_numpy(), p["v_um"].to_numpy()])
        return x - x[0], y - y[0]

    for cam in ("A", "B"):
        xs, ys = zip(*(rel(t, cam) for t in train), strict=True)
        x = np.column_stack([np.ones(sum(len(a) for a in xs)), np.vstack(xs)])
        coef, *_ = np.linalg.lstsq(x, np.vstack(ys), rcond=None)
        for t in hold:
            xh, yh = rel(t, cam)
            r = yh - np.column_stack([np.ones(len(xh)), xh]) @ coef
            r = r - r.mean(axis=0)
            res.append(r)
            per_run.setdefault(str(t["run"][0]), []).append(r)
    want = float(np.sqrt(np.mean(np.concatenate(res) ** 2)))
    ols = next(b for b in c.baselines if b.name == "ols")
    assert ols.holdout_rms_um == pytest.approx(want, rel=1e-9)
    for pr in ols.per_run:
        assert pr["rms_um"] == pytest.approx(
            float(np.sqrt(np.mean(np.concatenate(per_run[pr["run"]]) ** 2))), rel=1e-9
        )
    lo, hi = ols.holdout_rms_ci95
    assert lo < ols.holdout_rms_um < hi
    # The drift is linear in the temperatures and the noise white, 1 µm per axis: least
    # squares leaves the noise (less the one offset per held-out series it takes).
    assert 0.85 < ols.holdout_rms_um < 1.1
    doc = c.to_json()
    assert [b["name"] for b in doc["baselines"]] == ["ols", "lowpass_lasso"]
    assert set(doc["baselines"][0]) >= {"name", "n_params", "holdout_rms_um",
                                        "holdout_rms_ci95", "per_run"}  # fmt: skip
    json.dumps(doc)  # plain JSON


def test_cross_validation_never_splits_a_run() -> None:
    rng = np.random.default_rng(3)
    runs = np.repeat(["r1", "r2", "r3"], [40, 55, 30])
    t = rng.uniform(0, 1e5, len(runs))
    folds, how = cv_folds(runs, t)
    assert len(folds) == 3 and how.startswith("by run")
    for tr, te in folds:
        assert len(set(runs[te])) == 1
        assert not set(runs[tr]) & set(runs[te])
        assert len(tr) + len(te) == len(runs)
    # A single run: contiguous blocks of time, never single visits.
    one = np.array(["r1"] * 50)
    folds, how = cv_folds(one, t[:50])
    assert len(folds) == 5 and "contiguous blocks" in how
    order = np.argsort(t[:50])
    rank = np.empty(50, dtype=int)
    rank[order] = np.arange(50)
    for _, te in folds:
        r = np.sort(rank[te])
        assert len(te) == 10 and np.all(np.diff(r) == 1)
    # The LASSO actually fitted validates on those folds: none splits a training run.
    data = [_run("a", speed=0.3, day=0, noise_um=0.5, rng=rng),
            _run("b", speed=0.75, day=1, noise_um=0.5, rng=rng),
            _run("c", speed=0.5, day=2, noise_um=0.5, rng=rng)]  # fmt: skip
    f = features(data, RIG, smooth=False)
    fb = fit_baseline("lowpass_lasso", f, np.ones(f.visits.n, dtype=bool))
    for (cam, _ax), est in fb.estimators.items():
        run_of = f.visits.run[f.visits.camera == cam]
        lasso = est.steps[-1][1]
        assert len(lasso.cv) == 3
        for tr, te in lasso.cv:
            assert not set(run_of[tr]) & set(run_of[te])


def test_lowpass_is_the_first_order_response() -> None:
    # A step at t = 0 (from equilibrium at 0) on an irregular grid: 1 − e^(−t/τ) exactly,
    # the input held at each new sample over its step.
    t = np.cumsum(np.r_[0.0, np.random.default_rng(0).uniform(10, 200, 80)])
    x = np.r_[0.0, np.ones(80)][:, None]
    y = lowpass(t, x, 600.0)[:, 0]
    np.testing.assert_allclose(y[1:], 1 - np.exp(-(t[1:] - t[0]) / 600.0), atol=1e-12)


def test_bad_inputs_are_refused_in_one_line() -> None:
    rng = np.random.default_rng(5)
    a = _run("a", speed=0.3, day=0, noise_um=0.5, rng=rng)
    b = _run("b", speed=0.5, day=1, noise_um=0.5, rng=rng).filter(pl.col("camera") == "A")
    with pytest.raises(thermrs.InputError, match="no held-out run"):
        compare_baselines([a], [], RIG)
    with pytest.raises(thermrs.InputError, match="not one of"):
        compare_baselines([a], [b], RIG, models=("svm",))
    with pytest.raises(thermrs.InputError, match="held-out camera\\(s\\) B"):
        compare_baselines([b.with_columns(pl.lit("b0").alias("run"))],
                          [a.with_columns(pl.lit("a1").alias("run"))], RIG)  # fmt: skip
    assert MODELS[0] == "ols"


SCENARIO = (
    """format = "thermrs-scenario/1"
seed = 5
[[run]]
name = "s30"
speed_pct = 30
duration_min = 150
cycle_s = 150
start = "ambient"
[[run]]
name = "s75"
speed_pct = 75
duration_min = 150
cycle_s = 150
start = "continue"
idle_before_min = 60
[camera]
mode = "visits"
frames_per_visit = 1
[[effect]]
name = "joint_offset"
joint = "joint_a3"
temperature = "link3"
urad_per_k = 12.8
"""
    + FAST_NODES
)


@pytest.mark.slow
def test_diagnose_baselines_json_on_a_simulated_recording(tmp_path: Path) -> None:
    rig = str(thermrs.default_rig_path())
    sc = tmp_path / "sc.toml"
    sc.write_text(SCENARIO)
    rec = tmp_path / "r.mcap"
    ok(cli("simulate", "--rig", rig, "--scenario", str(sc), "-o", str(rec)))
    out = tmp_path / "d.json"
    p = ok(cli("diagnose", "--rig", rig, "--train", f"{rec}#s30", "--holdout", f"{rec}#s75",
               "--baselines", "--json", str(out), "--bootstrap", "0"))  # fmt: skip
    doc = json.loads(out.read_text())
    names = [b["name"] for b in doc["baselines"]]
    assert names == list(MODELS)
    for b in doc["baselines"]:
        lo, hi = b["holdout_rms_ci95"]
        assert lo <= b["holdout_rms_um"] <= hi and b["n_params"] >= 1
        assert [r["run"] for r in b["per_run"]] == ["r#s75"]
    comp = doc["baselines_comparison"]
    # The physical rows are the diagnosis's own numbers, scored the same way.
    assert comp["nominal"]["holdout_rms_um"] == pytest.approx(
        doc["baseline"]["holdout_rms_um"], rel=1e-9
    )
    assert comp["diagnosed"]["holdout_rms_um"] == pytest.approx(
        doc["how_far"]["holdout_rms_after_um"], rel=1e-9
    )
    assert comp["noise_floor_um"] == doc["noise_floor_um"]
    # By phase: the nominal model's, pooled from the diagnosis's own location table.
    for ph, got in comp["nominal"]["per_run"][0]["by_phase"].items():
        rows = [x for x in doc["location"] if x["run"] == "r#s75" and x["phase"] == ph]
        n = sum(x["n"] for x in rows)
        want = (sum(x["n"] * x["rms_um"] ** 2 for x in rows) / n) ** 0.5
        assert got == pytest.approx(want, rel=1e-9)
    # The table is rendered after the diagnosis.
    assert "Baselines" in p.stdout and "lowpass_lasso" in p.stdout
    # With a rule that is not --train/--holdout, refused in one line.
    bad(cli("diagnose", "--rig", rig, "--paper", "--baselines"), "--baselines")
    # The report's subsection shows the command's numbers (the diagnosis passed on, so that
    # both are of one diagnosis), with its figure.
    html = tmp_path / "rep.html"
    ok(cli("report", "--rig", rig, "--run", str(rec), "--train", f"{rec}#s30", "--diagnosis",
           str(out), "--baselines", "-o", str(html), "--quiet"))  # fmt: skip
    md = (tmp_path / "rep.md").read_text()
    assert "### Beside regressions on the temperatures" in md
    assert (tmp_path / "rep_files" / "baselines.svg").exists()
    for b in [comp["nominal"], comp["diagnosed"], *doc["baselines"]]:
        lo, hi = b["holdout_rms_ci95"]
        cell = f"{b['holdout_rms_um']:.2f} [{lo:.2f}, {hi:.2f}]"
        assert any(ln.startswith(f"| {b['name']} |") and cell in ln for ln in md.splitlines())
    # The best linear regression exported as a law, applied to the held-out run it was scored
    # on: it leaves what the comparison said.
    linear = [b for b in doc["baselines"] if b["name"] != "gbt"]
    best = min(linear, key=lambda b: b["holdout_rms_um"])
    assert comp["law"]["model"] == best["name"]
    law = tmp_path / "law.csv"
    p = ok(cli("compensate", "--rig", rig, "--diagnosis", str(out), "--model", "baseline",
               "-o", str(law), "--check", f"{rec}#s75"))  # fmt: skip
    t = pl.read_csv(law)
    assert t.height == 4 and set(t["model"]) == {best["name"]}
    assert f"Check on r#s75: {best['holdout_rms_um']:.2f} µm rms compensated." in p.stdout
    plain = tmp_path / "plain.json"
    plain.write_text(json.dumps({k: v for k, v in doc.items() if not k.startswith("baselines")}))
    bad(cli("compensate", "--rig", rig, "--diagnosis", str(plain), "--model", "baseline",
            "-o", str(tmp_path / "law2.csv")), "no baselines")  # fmt: skip


def test_the_exported_law_is_least_squares_with_intervals_that_hold_the_truth() -> None:
    from thermrs.analyses.baselines import BaselineLaw

    rng = np.random.default_rng(11)
    train = [_run("a", speed=0.3, day=0, noise_um=0.5, rng=rng),
             _run("b", speed=0.75, day=1, noise_um=0.5, rng=rng)]  # fmt: skip
    hold = [_run("c", speed=0.5, day=2, noise_um=0.5, rng=rng)]
    c = compare_baselines(train, hold, RIG, models=("ols", "lowpass_ridge"), draws=99,
                          smooth=False)  # fmt: skip
    doc = c.to_json()
    law = BaselineLaw.from_diagnosis(doc)
    assert law.model == "ols"  # the truth is linear in the temperatures
    covered = 0
    for row in law.doc["rows"]:
        cam, ax = row["camera"], row["axis"]
        # numpy's least squares on the same differences from the first visit, independently.
        xs, ys = [], []
        for t in train:
            p = t.filter(pl.col("camera") == cam).sort("t_ns")
            x = np.column_stack([p[f"{k}_c"].to_numpy() for k in sorted(TEMPS)])
            y = p[f"{ax}_um"].to_numpy()
            xs.append(x - x[0])
            ys.append(y - y[0])
        a = np.column_stack([np.ones(sum(len(v) for v in xs)), np.vstack(xs)])
        coef, *_ = np.linalg.lstsq(a, np.concatenate(ys), rcond=None)
        got = [row["coefficients"][f"d_{k}"] for k in sorted(TEMPS)]
        np.testing.assert_allclose([row["intercept_um"], *got], coef, rtol=1e-7, atol=1e-9)
        truth = dict(zip(TEMPS, COEF[(cam, ax)], strict=True))
        for k in TEMPS:
            lo, hi = row["coefficients_ci95"][f"d_{k}"]
            covered += lo <= truth[k] <= hi
    # 16 coefficients, each interval at 95 %: nearly all hold the truth.
    assert covered >= 13
    # Applied to the held-out run, the law leaves what the comparison scored.
    checked = law.check(hold, RIG)
    ols = next(b for b in c.baselines if b.name == "ols")
    assert checked["all_rms_um"] == pytest.approx(ols.holdout_rms_um, rel=1e-9)
    # Run c (50 %) heats the links within the 30–75 % runs' range; a 100 % run beyond it.
    assert not [w for w in checked["outside"] if "link" in w]
    hot = _run("h", speed=1.0, day=5, noise_um=0.5, rng=rng)
    said = law.check([hot], RIG)["outside"]
    assert any(w.startswith("run h: link2 spans 22.00–") for w in said), said
    assert any(w.startswith("run h: link3 spans 22.50–") for w in said), said
    # A standardised ridge's law, unfolded to the features' own units, predicts what the
    # fitted scikit-learn pipeline predicts.
    f = features([*train, *hold], RIG, smooth=False)
    fb = next(b for b in c.fitted if b.name == "lowpass_ridge")
    from thermrs.diagnose.baseline_law import _best_law

    one = _best_law([fb], {"lowpass_ridge": np.zeros((f.visits.n, 2))},
                    np.ones(f.visits.n, dtype=bool), f, np.isin(f.visits.run, ["a", "b"]),
                    seed=0)  # fmt: skip
    assert one is not None
    np.testing.assert_allclose(BaselineLaw(one, {}).predict(f), fb.predict(f), rtol=1e-9, atol=1e-9)
