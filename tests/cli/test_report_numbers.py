"""The report's numbers are the commands' (issue #46): on a simulated recording of two runs, the
page ``thermrs report --baselines`` writes (its Markdown twin) against the ``--json`` documents
of ``thermrs fit``, ``predict``, ``drift`` and ``diagnose --baselines`` run on the same runs,
each in its own process with no cache on disk, so that no command reads what another computed.
Every number compared is the command's, rounded to the digits the page prints; the diagnosis'
own summary stands on the page word for word. ``report --exclude X`` gives ``diagnose
--exclude X``'s diagnosis, and the page says what was excluded (also what a ``--diagnosis``
file excluded)."""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

import pytest

from tests.support.cli import bad, cli, ok

#: Nine commands on two one-hour runs: about a minute and a half.
pytestmark = pytest.mark.slow

#: No diagnosis read from another command's cache: each command computes its own.
NO_CACHE = {"THERMRS_CACHE_DIR": "off"}

#: An effect of the library, excluded (the recording carries none).
EXCLUDED = "thermal_lag"


def _run(*args: str) -> None:
    ok(cli(*args, env=NO_CACHE))


def _json(tmp: Path, name: str, *args: str) -> dict[str, Any]:
    """The command's ``--json`` document, with what it printed under ``"screen"``."""
    out = tmp / f"{name}.json"
    screen = ok(cli(*args, "--json", str(out), env=NO_CACHE)).stdout
    doc: dict[str, Any] = json.loads(out.read_text())
    return {**doc, "screen": screen}


@pytest.fixture(scope="module")
def world(two_runs: dict[str, Path], tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    """The report of run ``a`` (trained on) and ``b`` (held out), and the commands' documents;
    the same with ``--exclude``."""
    tmp = tmp_path_factory.mktemp("report-numbers")
    rig, t = str(two_runs["rig"]), str(two_runs["tables"])
    a, b = f"{t}#a", f"{t}#b"
    diagnosed = ("--rig", rig, "--train", a, "--holdout", b)
    _run("report", "--rig", rig, "--run", a, "--run", b, "--baselines", "-o", str(tmp / "r.html"),
         "--quiet")  # fmt: skip
    _run("report", "--rig", rig, "--run", a, "--run", b, "--exclude", EXCLUDED,
         "-o", str(tmp / "x.html"), "--quiet")  # fmt: skip
    return {
        "tmp": tmp,
        "rig": rig,
        "a": a,
        "b": b,
        "md": (tmp / "r.md").read_text(),
        "md_x": (tmp / "x.md").read_text(),
        "fit": _json(tmp, "fit", "fit", "--rig", rig, "--train", a),
        "predict": _json(tmp, "predict", "predict", "--rig", rig, "--train", a, "--run", b),
        "drift": _json(tmp, "drift", "drift", "--rig", rig, "--run", a, "--run", b),
        "diagnose": _json(tmp, "diag", "diagnose", *diagnosed, "--baselines"),
        "diagnose_x": _json(tmp, "diag-x", "diagnose", *diagnosed, "--exclude", EXCLUDED),
    }


def _cells(line: str) -> list[str]:
    return [c.strip() for c in line.strip().strip("|").split("|")]


def _tables(md: str, *header: str) -> list[list[dict[str, str]]]:
    """The Markdown tables whose header row starts with the cells ``header``, each as rows of
    cells by header."""
    lines, out = md.splitlines(), []
    for i, ln in enumerate(lines):
        cells = _cells(ln)
        if ln.startswith("|") and cells[: len(header)] == list(header):
            rows = []
            for row in lines[i + 2 :]:
                if not row.startswith("|"):
                    break
                # Of two columns with one header, the first is kept (the how-far table's
                # interval column has no header, like its first).
                pairs = list(zip(cells, _cells(row), strict=True))
                rows.append(dict(reversed(pairs)))
            out.append(rows)
    assert out, f"no table headed {header!r}"
    return out


def _table(md: str, *header: str) -> list[dict[str, str]]:
    """The first Markdown table whose header row starts with the cells ``header``."""
    return _tables(md, *header)[0]


def _same(cell: str, value: float, scale: float = 1.0) -> None:
    """The page's ``cell`` is ``value`` (× ``scale``) to the last digit it prints."""
    text = cell.replace("−", "-").replace("+", "")
    decimals = len(text.split(".")[1]) if "." in text else 0
    assert abs(float(text) - value * scale) <= 0.5 * 10**-decimals * (1 + 1e-9), (cell, value)


def test_table_7_is_predict_s_table(world: dict[str, Any]) -> None:
    rows = [r for r in _table(world["md"], "α") if r["α"] == "series"]
    want = [r for r in world["predict"]["table"] if r["alpha"] == "series"]
    assert len(rows) == len(want) == 2  # two cameras, one held-out run
    for page, cmd in zip(rows, want, strict=True):
        assert (page["camera"], page["run"], page["chip axis"]) == (
            cmd["camera"], cmd["run"], cmd["axis"])  # fmt: skip
        _same(page["α (×10⁻⁶/K)"], world["predict"]["alpha_per_k"]["series"], 1e6)
        _same(page["predicted (µm)"], cmd["predicted_um"])
        _same(page["measured (µm)"], cmd["measured_um"])
        _same(page["error (% or µm where the drift is within noise)"], cmd["error_pct"])
        _same(page["rms (µm)"], cmd["rms_centred_um"])
        _same(page["noise (µm)"], cmd["noise_um"])


def test_alpha_and_its_interval_are_fit_s(world: dict[str, Any]) -> None:
    (row,) = [r for r in _table(world["md"], "estimator") if r["estimator"] == "time-series"]
    a = world["fit"]["alpha_per_k"]
    _same(row["α (×10⁻⁶/K)"], a["value"], 1e6)
    lo, hi = row["95 % interval"].split(" – ")
    _same(lo, a["ci95"][0], 1e6)
    _same(hi, a["ci95"][1], 1e6)
    _same(row["rms (µm)"], world["fit"]["rms_um"])


def test_repeatability_is_drift_s(world: dict[str, Any]) -> None:
    iso = _table(world["md"], "run", "camera", "cold window (min from the run's first visit)")
    want = {(r["run"], r["camera"]): r for r in world["drift"]["iso9283"]["summary"]}
    assert len(iso) == len(want) == 4
    for page in iso:
        cmd = want[(page["run"], page["camera"])]
        for col, key in (("RP cold (µm)", "rp_cold_um"), ("RP warm (µm)", "rp_warm_um"),
                         ("dAP (µm)", "dap_um"), ("dRP (µm)", "drp_um")):  # fmt: skip
            _same(page[col], cmd[key])


def test_the_diagnosis_is_diagnose_s(world: dict[str, Any]) -> None:
    doc = world["diagnose"]
    # The diagnosis' own words, on the page as diagnose wrote them.
    assert doc["summary"] in world["md"]
    how = {r[""]: r for t in _tables(world["md"], "", "value") for r in t}
    _same(how["noise floor (visit to visit)"]["value"], doc["noise_floor_um"])
    _same(how["held-out RMS, nominal model"]["value"], doc["how_far"]["holdout_rms_before_um"])
    _same(
        how["held-out RMS, with the chosen effect"]["value"],
        doc["how_far"]["holdout_rms_after_um"],
    )
    assert doc["excluded"] == []
    assert "Excluded effects (`--exclude`): none." in world["md"]


def test_the_regressions_are_diagnose_baselines(world: dict[str, Any]) -> None:
    rows = {r["model"]: r for r in _table(world["md"], "model", "what", "parameters")}
    want = world["diagnose"]["baselines"]
    assert {b["name"] for b in want} <= set(rows) and len(want) >= 4
    for cmd in want:
        page = rows[cmd["name"]]
        assert int(page["parameters"]) == cmd["n_params"]
        rms, ci = page["held-out rms, µm [95 %]"].split(" [")
        _same(rms, cmd["holdout_rms_um"])
        for cell, value in zip(ci.rstrip("]").split(", "), cmd["holdout_rms_ci95"], strict=True):
            _same(cell, value)
        minus = page["minus the diagnosed model, µm [95 %]"].strip("[]").split(", ")
        for cell, value in zip(minus, cmd["minus_diagnosed_ci95"], strict=True):
            _same(cell, value)


def test_report_exclude_is_diagnose_exclude(world: dict[str, Any]) -> None:
    doc, plain = world["diagnose_x"], world["diagnose"]
    assert doc["excluded"] == [EXCLUDED]
    # What the exclusion changes is what diagnose says of it: the effects it could name.
    assert doc["summary"] != plain["summary"]
    assert doc["summary"] in world["md_x"] and plain["summary"] not in world["md_x"]
    status = doc["verdict"]["status"]
    assert re.search(rf"Verdict — {re.escape(status)}\b", world["md_x"])
    said = f"Excluded effects (`--exclude`): {EXCLUDED} — the diagnosis was made without them"
    assert said in world["md_x"] and said not in world["md"]
    # diagnose says it on the screen too.
    assert f"Excluded (--exclude, never named): {EXCLUDED}" in doc["screen"]
    assert "Excluded" not in plain["screen"]


def test_a_diagnosis_given_says_what_it_excluded(world: dict[str, Any]) -> None:
    tmp, rig, a, b = world["tmp"], world["rig"], world["a"], world["b"]
    given = tmp / "diag-x.json"  # diagnose --exclude's own file
    out = tmp / "given.html"
    _run("report", "--rig", rig, "--run", a, "--run", b, "--diagnosis", str(given),
         "-o", str(out), "--quiet")  # fmt: skip
    md = (tmp / "given.md").read_text()
    assert world["diagnose_x"]["summary"] in md
    assert f"Excluded effects (`--exclude`): {EXCLUDED} — " in md
    # Another exclusion than the file's: one line, exit 2, nothing written.
    other = tmp / "other.html"
    line = bad(cli("report", "--rig", rig, "--run", a, "--run", b, "--diagnosis", str(given),
                   "--exclude", "sensor_drift", "-o", str(other), "--quiet", env=NO_CACHE),
               "--exclude sensor_drift", EXCLUDED)  # fmt: skip
    assert "Traceback" not in line and not other.exists()
