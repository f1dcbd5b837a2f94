"""A colleague's second hour (issue #17), through the CLI where the user meets it: runs inside a
recording everywhere (report too), what a recording holds (`thermrs info`), the diagnosed model
put to use (`predict --diagnosis`, `compensate`) on a run the diagnosis never saw, and input
that cannot be right refused with its reason.

The recording: three 6-hour runs at 30/75/10 % in one file, a joint whose zero drifts with
link 3 (SPEC §6 ``joint_offset``, 12.8 µrad/K) that the nominal model leaves out; its
replicate is the same protocol with another seed (new noise, same physics)."""

from __future__ import annotations

import json
import math
import os
import re
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import polars as pl
import pytest
import thermrs
from mcap.reader import make_reader

REPO = Path(__file__).resolve().parents[2]
UR5 = REPO / "fixtures" / "rigs" / "ur5-two-cameras.toml"

SCENARIO = """format = "thermrs-scenario/1"
name = "three runs, a joint zero that drifts with link 3"
seed = 17
[[run]]
name = "s30"
speed_pct = 30
duration_min = 360
cycle_s = 300
start = "ambient"
[[run]]
name = "s75"
speed_pct = 75
duration_min = 360
cycle_s = 300
start = "continue"
idle_before_min = 240
[[run]]
name = "s10"
speed_pct = 10
duration_min = 360
cycle_s = 300
start = "continue"
[ambient]
start_c = 23.0
noise_c = 0.02
[camera]
mode = "visits"
frames_per_visit = 1
[output]
compression = "lz4"
[[node]]
name = "link2"
tau_min = 60.0
rise_saturating = { r0_k = 0.438342, span_k = 5.030472, s0 = 0.0964029 }
[[node]]
name = "link3"
tau_min = 90.0
rise_saturating = { r0_k = 1.602697, span_k = 6.041837, s0 = 0.1241591 }
[[node]]
name = "base"
tau_min = 600.0
rise_k = [0.10, 0.85, 0.50]
[[effect]]
name = "joint_offset"
joint = "joint_a3"
temperature = "link3"
urad_per_k = 12.8
"""
#: Visits per camera and run: 360 min / 300 s.
VISITS = 72


def cli(*args: str, env: dict[str, str] | None = None) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "thermrs", *args],
        capture_output=True,
        text=True,
        env={**os.environ, "THERMRS_DEBUG": "", **(env or {})},
    )


def ok(p: subprocess.CompletedProcess[str]) -> subprocess.CompletedProcess[str]:
    assert p.returncode == 0, p.stderr
    return p


def bad(p: subprocess.CompletedProcess[str], *words: str) -> str:
    assert p.returncode == 2, (p.returncode, p.stderr)
    # Besides the runs each file was found to hold (one line per file), one error line.
    lines = [ln for ln in p.stderr.strip().splitlines() if not ln.startswith("thermrs: --")]
    assert len(lines) == 1 and "Traceback" not in p.stderr, p.stderr
    for w in words:
        assert w in lines[0], (w, lines[0])
    return lines[0]


@pytest.fixture(scope="module")
def d(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """The recording, its replicate, its extracted tables and its diagnosis (30 % → 75 %)."""
    root = tmp_path_factory.mktemp("second-hour")
    sc = root / "jo.toml"
    sc.write_text(SCENARIO)
    rig = thermrs.default_rig_path()
    rec, rep = root / "jo.mcap", root / "jo2.mcap"
    ok(cli("simulate", "--rig", str(rig), "--scenario", str(sc), "-o", str(rec)))
    ok(cli("simulate", "--rig", str(rig), "--scenario", str(sc), "-o", str(rep), "--seed", "18"))
    ok(cli("extract", str(rec), "--rig", str(rig), "-o", str(root / "jo.parquet"), "--quiet"))
    diag = root / "d.json"
    ok(
        cli("diagnose", "--rig", str(rig), "--train", f"{rec}#s30", "--holdout", f"{rec}#s75",
            "--json", str(diag))
    )  # fmt: skip
    return {"root": root, "rig": rig, "rec": rec, "rep": rep, "diag": diag, "sc": sc}


# --- thermrs info ---------------------------------------------------------------------------


def test_info_says_what_the_recording_holds(d: dict[str, Path]) -> None:
    doc = json.loads(ok(cli("info", str(d["rec"]), "--rig", str(d["rig"]), "--json")).stdout)[0]
    # Every topic's count against the mcap package reading every message.
    counts: dict[str, int] = {}
    with open(d["rec"], "rb") as f:
        for _, ch, _ in make_reader(f).iter_messages():
            counts[ch.topic] = counts.get(ch.topic, 0) + 1
    assert {t["topic"]: t["messages"] for t in doc["topics"]} == counts
    roles = {t["topic"]: t["role"] for t in doc["topics"]}
    assert roles["/ccd_a/image_raw"].startswith("camera A")
    assert roles["/thermal/image_raw"] == "thermal camera"
    # The runs the scenario wrote, with one visit per camera and cycle each.
    runs = tomllib.loads(SCENARIO)["run"]
    assert [r["run"] for r in doc["runs"]] == [r["name"] for r in runs]
    assert all(r["source"] == "marker" for r in doc["runs"])
    for r, s in zip(doc["runs"], runs, strict=True):
        assert (r["end_ns"] - r["start_ns"]) / 60e9 == pytest.approx(s["duration_min"], abs=0.01)
        assert r["visits"] == 2 * VISITS
    frames = {c["camera"]: c["frames"] for c in doc["cameras"]}
    assert frames == {"A": 3 * VISITS, "B": 3 * VISITS}
    drives = {r["roi"]: r["drives"] for r in doc["rois"]}
    assert drives == {"link2": "a2", "link3": "d4", "base": ""}
    assert doc["losses"] == [] and doc["from_summary"]
    # ~15.7 h from the first to the last message: 3 × 6 h and a 4-hour idle.
    assert doc["duration_s"] / 3600 == pytest.approx(22.0, abs=0.1)


def test_info_on_a_cut_recording_and_one_without_markers(
    d: dict[str, Path], shared: Path, tmp_path: Path
) -> None:
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(d["rec"].read_bytes()[: d["rec"].stat().st_size // 2])
    p = cli("info", str(cut), "--rig", str(d["rig"]), "--json")
    assert p.returncode == 3, p.stderr
    assert "data loss" in p.stderr and str(cut) in p.stderr
    doc = json.loads(p.stdout)[0]
    assert not doc["from_summary"] and doc["losses"]
    # The marker written so far, and the visits after it split by idle gaps.
    assert [r["run"] for r in doc["runs"]] == ["s30", "unmarked1"]
    # An independent writer's recording without run markers: one run, split by gaps.
    sample = shared / "samples" / "kr15-sample.mcap"
    doc = json.loads(ok(cli("info", str(sample), "--json")).stdout)[0]
    with open(sample, "rb") as f:
        n = sum(1 for _ in make_reader(f).iter_messages())
    assert doc["messages"] == n
    assert [r["source"] for r in doc["runs"]] == ["gap"]


# --- the diagnosed model put to use ---------------------------------------------------------


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


def _run_temperatures(rec: Path, run: str) -> pl.DataFrame:
    (t,) = thermrs.runs.load_runs(f"{rec}#{run}", thermrs.load_rig()).tables
    return t.sort("camera", "t_ns")


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


# --- runs inside a recording, everywhere ---------------------------------------------------


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
    assert "3 runs: jo#s30, jo#s75, jo#s10" in p.stderr
    html = allr.read_text()
    assert all(f"jo#{r}" in html for r in ("s30", "s75", "s10"))
    # -o into a folder that does not exist: an error, nothing created.
    bad(cli("report", "--rig", rig, "--run", f"{d['rec']}#s30", "-o",
            str(tmp_path / "missing" / "r.html")), "does not exist")  # fmt: skip
    assert not (tmp_path / "missing").exists()


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


# --- what the README promises ---------------------------------------------------------------


def test_every_module_the_readme_names_is_reachable_after_import() -> None:
    code = (
        "import thermrs\n"
        "for m in ('diagnose', 'runs', 'report', 'stats', 'effects', 'signatures', 'inventory',"
        " 'compensate'):\n"
        "    getattr(thermrs, m)\n"
        "assert issubclass(thermrs.InternalError, thermrs.ThermrsError)\n"
        "assert callable(thermrs.diagnose.diagnose) and callable(thermrs.report.write_report)\n"
    )
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert p.returncode == 0, p.stderr


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


# --- input that cannot be right --------------------------------------------------------------


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


def test_diagnosing_runs_too_short_is_bad_input_not_a_crash(tmp_path: Path) -> None:
    rig = str(thermrs.default_rig_path())
    sc = tmp_path / "short.toml"
    sc.write_text(
        'format = "thermrs-scenario/1"\nseed = 3\n'
        '[[run]]\nname = "a"\nspeed_pct = 30\nduration_min = 1\ncycle_s = 60\n'
        'start = "ambient"\n'
        '[[run]]\nname = "b"\nspeed_pct = 75\nduration_min = 1\ncycle_s = 60\n'
        'start = "continue"\n'
    )
    rec = tmp_path / "short.mcap"
    ok(cli("simulate", "--rig", rig, "--scenario", str(sc), "-o", str(rec)))
    bad(cli("diagnose", "--rig", rig, "--train", f"{rec}#a", "--holdout", f"{rec}#b"),
        "visit(s); a diagnosis needs at least 3")  # fmt: skip
    # The library refuses what the command refuses.
    from thermrs.diagnose import diagnose
    from thermrs.runs import load_runs

    r = thermrs.load_rig(rig)
    with pytest.raises(thermrs.InputError, match=r"visit\(s\); a diagnosis needs at least 3"):
        diagnose(load_runs(f"{rec}#a", r).tables, load_runs(f"{rec}#b", r).tables, r)


def test_a_scenario_without_nodes_on_another_rig_says_so(tmp_path: Path) -> None:
    sc = tmp_path / "plain.toml"
    sc.write_text(
        'format = "thermrs-scenario/1"\nseed = 1\n[[run]]\nname = "a"\nspeed_pct = 30\n'
        'duration_min = 10\ncycle_s = 60\nstart = "ambient"\n'
    )
    msg = bad(cli("simulate", "--rig", str(UR5), "--scenario", str(sc), "-o",
                  str(tmp_path / "x.mcap")), "no [[node]]", "upper_arm")  # fmt: skip
    assert "add one [[node]] per ROI" in msg


# --- numbers shown only where they mean something -------------------------------------------

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


def test_a_gap_closed_beyond_the_gap_is_capped_and_implausible_candidates_marked(
    d: dict[str, Path],
) -> None:
    doc = json.loads(d["diag"].read_text())
    hf = doc["how_far"]
    # The JSON's share is capped at 1; the raw share beside it says by how much it overran.
    assert hf["gap_closed"] is None or hf["gap_closed"] <= 1.0
    if hf["gap_closed_raw"] is not None and hf["gap_closed_raw"] > 1.0:
        assert hf["gap_closed"] == 1.0 and hf["gap_closed_note"]
    p = ok(cli("diagnose", "--rig", str(d["rig"]), "--train", f"{d['rec']}#s30",
               "--holdout", f"{d['rec']}#s75"))  # fmt: skip
    for r in doc["ranking"]:
        if r["effect"] == "laser_tilt" and abs(r["params"]["tilt_deg"]) > 10:
            (row,) = [ln for ln in p.stdout.splitlines() if "tilt_deg = " in ln]
            assert "implausible" in row
    # A share beyond the gap is shown capped, with why (the floor read high).
    from thermrs.numbers import gap_closed

    shown = gap_closed(1.24, 1.73, 3.39)
    assert (
        shown.startswith("100 % (the effect removed 124 %")
        and "floor is estimated too high" in shown
    )


def test_the_bench_says_which_effects_it_could_not_test() -> None:
    # A tilted laser moves a drift-anchored spot by far less than the noise: the bench says it
    # did not run those cases and why, instead of scoring them.
    p = ok(cli("diagnose-bench", "--seeds", "1", "--hours", "4", "--effect", "laser_tilt",
               "--world", "white", "--snr", "1", "--nulls", "0"))  # fmt: skip
    lines = [ln for ln in p.stdout.splitlines() if ln.startswith("not run: white laser_tilt")]
    assert lines and all("reaches SNR" in ln for ln in lines)


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


def test_list_options_take_several_values_like_the_runs() -> None:
    # `--exclude A B` and `--between E1 E2 …` (as the issues write them) read like `--train A B`.
    from thermrs.cli.app import _expand_multi

    assert _expand_multi(["design", "--between", "a", "b", "c", "-o", "D"]) == [
        "design", "--between", "a", "--between", "b", "--between", "c", "-o", "D",
    ]  # fmt: skip
    assert _expand_multi(["diagnose", "--exclude", "x", "y", "--json", "j"]) == [
        "diagnose", "--exclude", "x", "--exclude", "y", "--json", "j",
    ]  # fmt: skip
