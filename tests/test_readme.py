"""The README's and docs/scenarios.md's examples run and say what they show (issue #13): the
library example as a doctest, the command-line examples through the CLI, the documented
scenario against the shipped file."""

from __future__ import annotations

import doctest
import re
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest
import thermrs

REPO = Path(__file__).resolve().parents[1]
README = REPO / "README.md"
SCENARIOS_DOC = REPO / "docs" / "scenarios.md"


def blocks(path: Path, lang: str) -> list[str]:
    """The fenced code blocks of one language in a Markdown file."""
    return re.findall(rf"^```{lang}\n(.*?)^```", path.read_text(), flags=re.S | re.M)


def cli(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "thermrs", *args], capture_output=True, text=True, cwd=cwd
    )


@pytest.mark.slow
def test_readme_python_examples_run(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    code = blocks(README, "python")
    assert len(code) >= 2 and all(">>>" in c for c in code)
    # The examples name shipped files relative to the repository (fixtures/...) and write
    # beside them: run them in a scratch folder that sees the repository's fixtures.
    (tmp_path / "fixtures").symlink_to(REPO / "fixtures")
    monkeypatch.chdir(tmp_path)
    parser = doctest.DocTestParser()
    test = parser.get_doctest("\n".join(code), {}, "README.md", str(README), 0)
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    runner.run(test)
    result = runner.summarize(verbose=False)
    assert result.attempted >= 10
    assert result.failed == 0
    assert not any(p.name.startswith("rigs") for p in tmp_path.iterdir())


def _matches(shown: str, got: str) -> bool:
    """``got`` is the line shown, with ``...`` standing for anything."""
    pattern = ".*".join(re.escape(part) for part in shown.split("..."))
    return re.fullmatch(pattern, got) is not None


def test_readme_rig_error_example(tmp_path: Path) -> None:
    (example,) = [b for b in blocks(README, "text") if "$ thermrs rig my-rig.toml" in b]
    shown = example.splitlines()[1]
    # The embedded rig with the mistake the README shows: camera[1]'s `topic` spelt `tpoic`.
    text = thermrs.default_rig_path().read_text().splitlines(keepends=True)
    cam = [i for i, ln in enumerate(text) if ln.strip() == "[[camera]]"][1]
    topic = next(i for i in range(cam, len(text)) if text[i].startswith("topic ="))
    text[topic] = text[topic].replace("topic", "tpoic", 1)
    (tmp_path / "my-rig.toml").write_text("".join(text))
    p = cli("rig", "my-rig.toml", cwd=tmp_path)
    assert p.returncode == 2
    assert p.stderr.count("\n") == 1
    assert _matches(shown, p.stderr.strip()), (shown, p.stderr)


def test_documented_scenario_is_the_shipped_one_and_its_error_example_holds(
    tmp_path: Path,
) -> None:
    (toml_block,) = blocks(SCENARIOS_DOC, "toml")
    shipped = REPO / "fixtures" / "scenarios" / "two-runs-thermal-lag.toml"
    assert tomllib.loads(toml_block) == tomllib.loads(shipped.read_text())
    (example,) = [b for b in blocks(SCENARIOS_DOC, "text") if "bad.toml" in b]
    shown = example.splitlines()[1]
    (tmp_path / "bad.toml").write_text(toml_block.replace("speed_pct = 30", "speed_pct = 130", 1))
    (tmp_path / "rig.toml").write_text(thermrs.default_rig_path().read_text())
    p = cli("simulate", "--rig", "rig.toml", "--scenario", "bad.toml", "-o", "x.mcap",
            cwd=tmp_path)  # fmt: skip
    assert p.returncode == 2
    assert p.stderr.strip() == shown, (shown, p.stderr)


def test_every_effect_of_the_spec_is_documented() -> None:
    doc = SCENARIOS_DOC.read_text()
    spec_effects = [
        "alpha_per_link",
        "thermal_lag",
        "unmodelled_length",
        "fixture_drift",
        "laser_tilt",
        "joint_offset",
        "nonlinear_alpha",
        "sensor_drift",
    ]
    for name in spec_effects:
        assert f"| `{name}` |" in doc, name


@pytest.mark.slow
@pytest.mark.parametrize(
    "name", sorted(p.name for p in (REPO / "fixtures" / "scenarios").glob("*.toml"))
)
def test_shipped_scenarios_parse_and_short_ones_simulate(name: str, tmp_path: Path) -> None:
    path = REPO / "fixtures" / "scenarios" / name
    doc = tomllib.loads(path.read_text())
    minutes = sum(r["duration_min"] for r in doc["run"])
    if minutes > 240:
        # Long scenarios (the paper's 45 hours): parse and validate only, with the rig, by
        # starting the simulator and stopping it at its first cycle.
        pytest.skip(f"{name}: {minutes} simulated minutes; parsed by test_simulate")
    if minutes > 6:
        # Simulated as shipped but for its runs' lengths, 3 minutes each: the same models,
        # effects and formats, a tenth of the frames (continuous cameras make thousands).
        import tomli_w

        for r in doc["run"]:
            r["duration_min"] = min(r["duration_min"], 3)
            r.pop("idle_before_min", None)
        path = tmp_path / name
        path.write_text(tomli_w.dumps(doc))
    sim = thermrs.simulate.simulate(thermrs.default_rig_path(), path, tmp_path / "s.mcap")
    assert sorted(set(sim.frames["run"])) == sorted(r["name"] for r in doc["run"])
    ex = thermrs.extract(sim.recording, thermrs.default_rig_path())
    assert not ex.report.data_loss
    assert ex.frames.filter(status="ok").height > 0
    effects = [e["name"] for e in doc.get("effect", [])]
    assert [e["name"] for e in sim.scenario.get("effect", [])] == effects


def test_every_module_the_readme_names_is_reachable_after_import() -> None:
    code = (
        "import thermrs\n"
        "for m in ('diagnose', 'runs', 'report', 'stats', 'effects', 'signatures', 'inventory',"
        " 'compensate'):\n"
        "    getattr(thermrs, m)\n"
        "assert issubclass(thermrs.InternalError, thermrs.ThermrsError)\n"
        "assert callable(thermrs.diagnose.diagnose) and callable(thermrs.report.write_document)\n"
    )
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
