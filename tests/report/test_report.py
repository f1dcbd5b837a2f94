"""`thermrs report` (issue #11): the report as a person sees it, and its numbers.

- The demo (`thermrs report --demo`, the real one, once per session) is opened in headless
  Chromium (Debian's `chromium`, driven by Playwright over the DevTools protocol with
  `executable_path`; Playwright's own browser download is never used): it loads with no console
  error, no request leaves the file, every section and figure is there and drawn, and a
  screenshot of its top is kept (in the test's tmp folder and `bench-out/report/`).
- A small campaign (two simulated 90-minute runs, extracted with `thermrs extract`): every
  number sampled from the `--json` outputs of `thermrs fit`, `predict`, `drift` (and
  `diagnose`, once it exists) is found, formatted, in the report.
- Missing inputs (one run only, no thermal readings, no diagnoser) are stated where the
  section would be; a hand-made diagnosis result renders (a rendering test only).
"""

from __future__ import annotations

import json
import re
import shutil
import subprocess
import sys
from html.parser import HTMLParser
from pathlib import Path
from typing import Any
from urllib.parse import unquote

import polars as pl
import pytest
import thermrs
from thermrs.analyses.report import write_report
from thermrs.analyses.report_runs import load_run
from thermrs.report import find_chromium
from thermrs.report.document import SECTION_IDS

from tests.support.scenarios import FAST_NODES, WARM_UP_90_MIN

#: Simulations and campaigns of minutes: skipped by `pytest -m "not slow"`.
pytestmark = pytest.mark.slow

REPO = Path(__file__).resolve().parents[2]
ARTEFACTS = REPO / "bench-out" / "report"


def run_cli(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "thermrs", *args],
        capture_output=True,
        text=True,
        check=False,
        cwd=cwd,
    )


class _Text(HTMLParser):
    """The text a reader sees (no markup, no SVG paths)."""

    def __init__(self) -> None:
        super().__init__()
        self.parts: list[str] = []

    def handle_data(self, data: str) -> None:
        self.parts.append(data)


def visible_text(html: str) -> str:
    p = _Text()
    p.feed(html)
    return " ".join(p.parts)


def cells(html: str) -> set[str]:
    """Every table cell's text."""
    return {html_unescape(c) for c in re.findall(r"<td[^>]*>(.*?)</td>", html)}


def html_unescape(s: str) -> str:
    import html as h

    return h.unescape(s)


# --- the browser ---------------------------------------------------------------------------


def browse(html: Path, shot: Path) -> dict[str, Any]:
    """Open ``html`` in headless Chromium; what a person would see, and what it asked for."""
    exe = find_chromium()
    if exe is None:
        pytest.skip("no Chromium (Debian: apt-get install chromium; .ci/run installs it)")
    sync_api = pytest.importorskip("playwright.sync_api")
    console: list[tuple[str, str]] = []
    errors: list[str] = []
    requests: list[str] = []
    with sync_api.sync_playwright() as p:
        browser = p.chromium.launch(executable_path=exe, args=["--no-sandbox"])
        try:
            page = browser.new_page(viewport={"width": 1200, "height": 900})
            page.on("console", lambda m: console.append((m.type, m.text)))
            page.on("pageerror", lambda e: errors.append(str(e)))
            page.on("request", lambda r: requests.append(r.url))
            page.goto(html.resolve().as_uri(), wait_until="load")
            sections = page.eval_on_selector_all("section[id]", "els => els.map(e => e.id)")
            figures = page.eval_on_selector_all(
                "figure[data-figure]",
                """els => els.map(e => {
                    const s = e.querySelector('svg');
                    const r = s ? s.getBoundingClientRect() : {width: 0, height: 0};
                    return {name: e.dataset.figure, w: r.width, h: r.height,
                            paths: s ? s.querySelectorAll('path').length : 0,
                            text: s ? s.textContent : ''};
                })""",
            )
            title = page.title()
            shot.parent.mkdir(parents=True, exist_ok=True)
            page.screenshot(path=str(shot))
        finally:
            browser.close()
    return {
        "console": console,
        "errors": errors,
        "requests": requests,
        "sections": sections,
        "figures": figures,
        "title": title,
    }


def keep(path: Path) -> None:
    """Keep a test artefact under bench-out/report/ too."""
    ARTEFACTS.mkdir(parents=True, exist_ok=True)
    shutil.copy2(path, ARTEFACTS / path.name)


# --- the demo ------------------------------------------------------------------------------


@pytest.fixture(scope="session")
def demo(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    d = tmp_path_factory.mktemp("demo")
    out = d / "demo.html"
    r = run_cli("report", "--demo", "-o", str(out), cwd=d)
    assert r.returncode == 0, r.stderr
    return {"dir": d, "html": out, "stderr": r.stderr}


def test_demo_in_chromium(demo: dict[str, Any]) -> None:
    shot = demo["dir"] / "report-demo-top.png"
    seen = browse(demo["html"], shot)
    keep(shot)
    assert not seen["errors"], seen["errors"]
    bad = [m for m in seen["console"] if m[0] in ("error", "warning")]
    assert not bad, bad
    # The only request is the file itself: nothing leaves it.
    assert seen["requests"] == [demo["html"].resolve().as_uri()], seen["requests"]
    for sid in SECTION_IDS:
        assert sid in seen["sections"], f"section {sid} missing"
    for run in ("run1", "run2", "run3"):
        assert f"run-{run}" in seen["sections"]
    names = {f["name"] for f in seen["figures"]}
    expected = {
        "overview",
        "rig",
        "run-run1",
        "run-run2",
        "run-run3",
        "prediction-run2",
        "prediction-run3",
        "iso9283",
    }
    assert expected <= names, names
    for f in seen["figures"]:
        # Drawn at a readable size, with lines and labelled axes.
        assert f["w"] > 500 and f["h"] > 150, f["name"]
        assert f["paths"] > 5, f["name"]
    run1 = next(f for f in seen["figures"] if f["name"] == "run-run1")
    for label in ("µm", "°C", "h", "camera A", "camera B", "link2", "link3"):
        assert label in run1["text"], label
    assert shot.stat().st_size > 10_000


def test_demo_content(demo: dict[str, Any]) -> None:
    html = demo["html"].read_text()
    size = demo["html"].stat().st_size
    assert size < 3_000_000, f"{size / 1e6:.1f} MB is too large to mail"
    # No script, nothing fetched: no src/href/url() to anywhere but inside the file.
    assert "<script" not in html
    assert not re.search(r"""(src|href)\s*=\s*["'](?!#)|url\((?!#)""", html)
    text = visible_text(html)
    # The paper's Table 4 is printed beside the simulated runs.
    for printed in ("131", "120", "-40", "28.10", "30.65"):
        assert printed in text
    md = demo["html"].with_suffix(".md").read_text()
    assert md.startswith("# thermrs demo")
    figs = re.findall(r"!\[[^\]]*\]\(([^)]+\.svg)\)", md)
    assert len(figs) >= 8
    for f in figs:
        assert "#" not in f and (demo["html"].parent / unquote(f)).read_text().startswith("<svg")
    # Progress on the terminal: every stage named.
    for stage in ("simulating", "extracting", "fitting α", "predicting", "writing the report"):
        assert stage in demo["stderr"], stage


# --- a small campaign: the report's numbers are the --json outputs' ------------------------


@pytest.fixture(scope="session")
def campaign(tmp_path_factory: pytest.TempPathFactory, paper_rig: thermrs.Rig) -> dict[str, Any]:
    from thermrs.simulate import simulate

    d = tmp_path_factory.mktemp("campaign")
    paths = {}
    for name, seed, speed in (("warm", 1, 30), ("fast", 2, 75)):
        sc = d / f"{name}.toml"
        text = WARM_UP_90_MIN.format(seed=seed).replace("speed_pct = 30", f"speed_pct = {speed}")
        sc.write_text(text + FAST_NODES)
        rec = simulate(paper_rig, sc, d / f"{name}.mcap").recording
        out = d / f"{name}.parquet"
        r = run_cli("extract", str(rec), "--rig", paper_rig.source, "-o", str(out), "--quiet")
        assert r.returncode == 0, r.stderr
        paths[name] = {"mcap": rec, "tables": out}
    return {"dir": d, "paths": paths}


def test_numbers_are_the_json_outputs(campaign: dict[str, Any], paper_rig: thermrs.Rig) -> None:
    d: Path = campaign["dir"]
    warm, fast = (str(campaign["paths"][k]["tables"]) for k in ("warm", "fast"))
    rig = paper_rig.source
    out = d / "r.html"
    r = run_cli("report", "--rig", rig, "--run", warm, fast, "-o", str(out))
    assert r.returncode == 0, r.stderr
    html = out.read_text()
    got = cells(html)

    def json_of(*args: str) -> Any:
        p = d / "x.json"
        res = run_cli(*args, "--json", str(p))
        assert res.returncode == 0, res.stderr
        return json.loads(p.read_text())

    fit = json_of("fit", "--rig", rig, "--train", warm)
    a = fit["alpha_per_k"]
    assert f"{a['value'] * 1e6:.3f}" in got
    assert f"{a['ci95'][0] * 1e6:.3f} – {a['ci95'][1] * 1e6:.3f}" in got
    assert f"{fit['rms_um']:.3f}" in got
    for se in fit["start_end"].values():
        for v in [*se["per_camera"].values(), se["mean"]]:
            assert f"{v['value'] * 1e6:.3f}" in got

    pred = json_of("predict", "--rig", rig, "--train", warm, "--run", fast)
    assert pred["table"]
    for row in pred["table"]:
        for key, fmt in (
            ("predicted_um", ".2f"),
            ("measured_um", ".2f"),
            ("error_pct", "+.2f"),
            ("rms_centred_um", ".3f"),
            ("noise_um", ".3f"),
        ):
            assert format(row[key], fmt) in got, (key, row)

    drift = json_of("drift", "--rig", rig, "--run", warm, fast)
    fitted = [c for c in drift["curves"] if c["tau_min"] is not None]
    assert len(fitted) >= 6
    for c in fitted:
        assert f"{c['tau_min']:.1f}" in got and f"{c['y0']:.2f}" in got, c
        if c["tau_min_se"] is not None:
            assert f"{c['tau_min_se']:.1f}" in got, c
    for s in drift["iso9283"]["summary"]:
        for key in ("rp_cold_um", "rp_warm_um", "dap_um"):
            if s[key] is not None:
                assert f"{s[key]:.2f}" in got, (key, s)
    # The diagnosis: the numbers `thermrs diagnose` prints.
    diag = json_of("diagnose", "--rig", rig, "--train", warm, "--holdout", fast)
    assert f"{diag['baseline']['holdout_rms_um']:.3f}" in got
    assert f"{diag['noise_floor_um']:.3f}" in got
    for rank in diag["ranking"]:
        assert f"{rank['holdout_rms_um']:.3f}" in got


def test_report_shows_the_diagnosis_file_it_is_given(
    campaign: dict[str, Any], paper_rig: thermrs.Rig
) -> None:
    """`report --diagnosis D.json` shows that diagnosis (its numbers, its figure), not one made
    again; a diagnosis of other runs is refused in one line."""
    d: Path = campaign["dir"]
    warm, fast = (str(campaign["paths"][k]["tables"]) for k in ("warm", "fast"))
    rig = paper_rig.source
    p = d / "given.json"
    r = run_cli(
        "diagnose", "--rig", rig, "--train", warm, "--holdout", fast, "--json", str(p), "--verbose"
    )
    assert r.returncode == 0, r.stderr
    # Piped: a line per stage with the seconds since the start; --verbose: each stage's time.
    lines = r.stderr.splitlines()
    for stage in ("baseline and floor", "candidates", "verdict"):
        assert any(re.match(rf"thermrs diagnose: {stage} \(\d+\.\d s\)$", ln) for ln in lines)
    assert re.search(r"thermrs diagnose: +\d+\.\d\d s  in all", r.stderr), r.stderr
    doc = json.loads(p.read_text())
    res = doc["residuals"]
    assert {"run", "role", "camera", "axis", "t_h", "baseline_um", "after_um"} <= set(res)
    assert set(res["run"]) == {r["run"] for r in doc["baseline"]["per_run"]}
    # Marked so that a diagnosis made again could not show the same.
    doc["summary"] = "A sentence only the given file carries."
    doc["noise_floor_um"] = 1.2346
    p.write_text(json.dumps(doc))
    out = d / "given.html"
    r = run_cli("report", "--rig", rig, "--run", warm, fast, "--diagnosis", str(p), "-o", str(out))
    assert r.returncode == 0, r.stderr
    assert "diagnosing" not in r.stderr
    html = out.read_text()
    text = visible_text(html)
    assert "A sentence only the given file carries." in text
    assert "1.235" in cells(html)
    assert f"{doc['baseline']['holdout_rms_um']:.3f}" in cells(html)
    sec = html[html.index('<section id="diagnosis">') : html.index('<section id="extraction">')]
    assert 'data-figure="diagnosis"' in sec
    # The same file with the runs' roles swapped: not this diagnosis.
    swapped = ("--run", fast, warm, "--diagnosis", str(p), "-o", str(out), "--quiet")
    r = run_cli("report", "--rig", rig, *swapped)
    assert r.returncode == 2
    # Besides the runs each file holds (told as every command tells them): one line.
    lines = [ln for ln in r.stderr.splitlines() if ln.strip() and not ln.startswith("thermrs: --")]
    assert len(lines) == 1 and "the diagnosis was made with train runs" in lines[0], r.stderr
    bad = d / "not-a-diagnosis.json"
    bad.write_text('{"alpha": 1}')
    r = run_cli("report", "--rig", rig, "--run", warm, fast, "--diagnosis", str(bad))
    assert r.returncode == 2 and "not a `thermrs diagnose --json` document" in r.stderr


def test_recording_input_shows_extraction(campaign: dict[str, Any], paper_rig: thermrs.Rig) -> None:
    """From the recording itself the extraction's report is shown; from tables it is said to be
    unavailable. One run only: prediction in-sample and no diagnosis, both stated."""
    rec = campaign["paths"]["warm"]["mcap"]
    run = load_run(rec, paper_rig)
    out = campaign["dir"] / "one.html"
    w = write_report(out, runs=[run], rig=paper_rig, markdown=False)
    text = visible_text(out.read_text())
    assert w.markdown is None
    assert "messages per topic" in text and "No message was skipped" in text
    assert "One run only" in text
    diag = text[text.index("Diagnosis") :]
    assert "Not shown" in diag and "held out" in diag


def test_no_thermal_readings_stated(
    campaign: dict[str, Any], paper_rig: thermrs.Rig, tmp_path: Path
) -> None:
    """Extracted tables whose temperatures table is empty: every section that needs them says
    so, and the report is still written."""
    src = campaign["paths"]["warm"]["tables"]
    stem = src.name[: -len(".parquet")]
    for part in ("", ".visits", ".joints"):
        shutil.copy(src.with_name(f"{stem}{part}.parquet"), tmp_path / f"cold{part}.parquet")
    temps = pl.read_parquet(src.with_name(f"{stem}.temperatures.parquet"))
    temps.clear().write_parquet(tmp_path / "cold.temperatures.parquet")
    out = tmp_path / "cold.html"
    r = run_cli(
        "report", "--rig", paper_rig.source, "--run", str(tmp_path / "cold.parquet"), "-o", str(out)
    )
    assert r.returncode == 0, r.stderr
    text = visible_text(out.read_text())
    assert "No thermal readings in cold" in text
    assert "α could not be fitted" in text
    for sid in SECTION_IDS:
        assert f'id="{sid}"' in out.read_text()


def test_no_joint_states_stated(
    campaign: dict[str, Any], paper_rig: thermrs.Rig, tmp_path: Path
) -> None:
    src = campaign["paths"]["warm"]["tables"]
    stem = src.name[: -len(".parquet")]
    for part in ("", ".visits", ".temperatures"):
        shutil.copy(src.with_name(f"{stem}{part}.parquet"), tmp_path / f"stiff{part}.parquet")
    joints = pl.read_parquet(src.with_name(f"{stem}.joints.parquet"))
    joints.clear().write_parquet(tmp_path / "stiff.joints.parquet")
    run = load_run(tmp_path / "stiff.parquet", paper_rig)
    out = tmp_path / "stiff.html"
    write_report(out, runs=[run], rig=paper_rig, markdown=False)
    text = visible_text(out.read_text())
    assert "stiff: no joint states" in text


class _HandMadeDiagnosis:
    """A rendering test only: a made-up result in the interface's shape (no numbers checked
    against anything but themselves)."""

    def __init__(self, runs: list[str]) -> None:
        self.residuals = pl.DataFrame(
            {
                "run": runs[-1:] * 4,
                "role": ["holdout"] * 4,
                "camera": ["A", "A", "B", "B"],
                "axis": ["u", "v", "u", "v"],
                "t_ns": [0, 0, 0, 0],
                "t_h": [0.0, 0.0, 0.0, 0.0],
                "baseline_um": [1.0, -1.0, 0.5, 0.2],
                "after_um": [0.1, -0.1, 0.05, 0.02],
                "phase": ["warm-up"] * 4,
            }
        )

    def check_runs(self, train: list[str], holdout: list[str], **_: Any) -> None:
        """Made of any runs (the interface's check, passed)."""

    def to_json(self) -> dict[str, Any]:
        return {
            "noise_floor_um": 0.123,
            "baseline": {
                "alpha_per_k": {"value": 2.1e-5, "ci95": [2.0e-5, 2.2e-5]},
                "train_rms_um": 0.5,
                "holdout_rms_um": 4.567,
                "holdout_max_um": 9.0,
            },
            "location": [
                {
                    "run": "fast",
                    "camera": "A",
                    "axis": "v",
                    "phase": "warm-up",
                    "rms_um": 3.0,
                    "share": 0.61,
                    "n": 40,
                }
            ],
            "drivers": [{"driver": "link3 rate", "corr": 0.8, "p": 1e-6}],
            "whiteness": {"ljung_box_p": 1e-9, "rho1": 0.9, "n_eff": 12.0, "white": False},
            "ranking": [
                {
                    "effect": "thermal_lag",
                    "params": {"tau_min": 24.5},
                    "train_rms_um": 0.2,
                    "holdout_rms_um": 0.321,
                    "shrink": 0.93,
                    "evidence": {"delta_aicc": -55.0, "placebo_beaten": True},
                }
            ],
            "confounded": [
                {
                    "effects": ["thermal_lag", "sensor_drift"],
                    "cos": 0.97,
                    "separate_by": "a run that cools down",
                }
            ],
            "verdict": {
                "status": "identified",
                "effect": "thermal_lag",
                "params": {"tau_min": 24.5},
                "confounded_with": [],
                "holdout_rms_um": 0.321,
                "reason": "it beats its placebo.",
            },
            "how_far": {
                "holdout_rms_before_um": 4.567,
                "holdout_rms_after_um": 0.321,
                "holdout_max_before_um": 9.0,
                "holdout_max_after_um": 0.8,
                "gap_closed": 0.93,
            },
            "summary": "The structure lags the surface by about 25 minutes.",
        }


def test_diagnosis_section_renders(campaign: dict[str, Any], paper_rig: thermrs.Rig) -> None:
    # The rig's file path serves as the rig.
    runs = [load_run(campaign["paths"][k]["tables"], paper_rig.source) for k in ("warm", "fast")]
    out = campaign["dir"] / "diag.html"
    diag = _HandMadeDiagnosis([r.name for r in runs])
    # A stand-in of the Diagnosis interface, not a Diagnosis.
    write_report(
        out,
        runs=runs,
        rig=paper_rig.source,
        diagnosis=diag,  # type: ignore[arg-type]
        markdown=True,
    )
    html = out.read_text()
    sec = html[html.index('<section id="diagnosis">') : html.index('<section id="extraction">')]
    text = visible_text(sec)
    for s in (
        "identified thermal_lag (tau_min = 24.5)",
        "4.567",
        "0.321",
        "93.0 %",
        "a run that cools down",
        "link3 rate",
        "structured (not noise)",
        "The structure lags the surface",
    ):
        assert s in text, s
    assert 'data-figure="diagnosis"' in sec
    # The summary at the top carries the diagnosis' own sentence.
    top = html[: html.index('<section id="rig">')]
    assert "The structure lags the surface" in top


def test_pdf(campaign: dict[str, Any], paper_rig: thermrs.Rig) -> None:
    if find_chromium() is None:
        pytest.skip("no Chromium")
    out = campaign["dir"] / "p.html"
    r = run_cli(
        "report",
        "--rig",
        paper_rig.source,
        "--pdf",
        "--no-markdown",
        "-o",
        str(out),
        "--run",
        str(campaign["paths"]["warm"]["tables"]),
    )
    assert r.returncode == 0, r.stderr
    pdf = out.with_suffix(".pdf").read_bytes()
    assert pdf.startswith(b"%PDF") and len(pdf) > 20_000
    assert not out.with_suffix(".md").exists()


@pytest.mark.parametrize(
    ("args", "message"),
    [
        ([], "give --run RUN… (and --rig RIG), or --demo"),
        (["--run", "x.mcap"], "give --rig RIG"),
        (["--demo", "--run", "x.mcap"], "--demo takes no --rig, --run or --train"),
        (["--rig", "RIG", "--run", "nope.mcap"], "nope.mcap: no such file"),
    ],
)
def test_bad_input_one_line(args: list[str], message: str) -> None:
    args = [str(thermrs.default_rig_path()) if a == "RIG" else a for a in args]
    r = run_cli("report", *args)
    assert r.returncode == 2, r.stderr
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and message in lines[0], r.stderr


def test_help_does_not_load_matplotlib() -> None:
    code = "import sys, thermrs.cli; print('matplotlib' in sys.modules)"
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert p.stdout.strip() == "False"
    r = run_cli("report", "--help")
    assert r.returncode == 0 and "--demo" in r.stdout
