"""``thermrs report --demo``: the paper's three runs simulated, extracted, fitted, predicted,
diagnosed and reported, from data shipped in the package.

- the rig: the embedded KR 15/2 paper rig (``thermrs/data/kr15-paper.toml``);
- the scenario: ``thermrs/data/demo-scenario.toml`` — the paper's three 15-hour runs (30, 75
  and 10 % speed; 10 h of cooling before Run 2, Run 3 straight after it) and whatever SPEC §6
  effect it switches on. Changing the demo is a change of that one file. Lines of it that
  start with ``#:`` are the demo's own explanation, printed at the top of the report (which
  effect it carries, and why).

The simulator writes one recording of the three runs; it is extracted once and cut into the
three runs at the scenario's own schedule (the times the simulator reports for each run's
frames and thermal samples), as if each run had been recorded on its own. Run 1 trains,
Runs 2 and 3 are held out, as in the paper.
"""

from __future__ import annotations

import json
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING

import polars as pl

from thermrs.analyses.report import write_report
from thermrs.analyses.report_runs import run_from_extraction
from thermrs.rig import load_rig

if TYPE_CHECKING:  # pragma: no cover
    from thermrs.report import Written
    from thermrs.report.data import RunInput

__all__ = ["DemoResult", "DemoRuns", "demo_scenario_path", "run_demo", "simulate_demo"]

#: ``progress(stage, done, total)``: stage names, and bytes or steps done of a total (0: none).
DemoProgress = Callable[[str, int, int], None]


@dataclass(frozen=True)
class DemoResult:
    """What the demo wrote, and how long each stage took (seconds)."""

    written: Written
    recording: Path
    timings: dict[str, float]


def demo_scenario_path() -> Path:
    """The demo's scenario file shipped in the package."""
    return Path(str(resources.files("thermrs") / "data" / "demo-scenario.toml"))


def explanation(scenario_text: str) -> str:
    """The scenario's ``#:`` lines, joined into one paragraph."""
    lines = [ln[2:].strip() for ln in scenario_text.splitlines() if ln.startswith("#:")]
    return " ".join(x for x in lines if x)


def _effects_sentence(doc: dict[str, object]) -> str:
    effects = doc.get("effect") or []
    assert isinstance(effects, list)
    if not effects:
        return "The scenario switches on no SPEC §6 effect: the nominal model is the truth."
    parts = []
    for e in effects:
        params = ", ".join(f"{k} = {v}" for k, v in e.items() if k != "name" and v is not None)
        parts.append(f"{e['name']} ({params})")
    return "The scenario switches on the SPEC §6 effect " + "; ".join(parts) + "."


@dataclass(frozen=True)
class DemoRuns:
    """The demo's runs, extracted and cut, and what the report says about them."""

    runs: list[RunInput]
    recording: Path
    intro: str
    timings: dict[str, float]


def simulate_demo(
    workdir: str | Path,
    *,
    scenario: str | Path | None = None,
    reuse: bool = False,
    progress: DemoProgress | None = None,
) -> DemoRuns:
    """Simulate the demo scenario into ``workdir``, extract the recording and cut it into its
    runs (see the module docstring). With ``reuse``, a recording this function simulated into
    ``workdir`` before (``demo.mcap`` and its truth files) is used instead of simulating again
    (it must have been simulated from the same scenario)."""
    from thermrs.ingest import extract
    from thermrs.simulate import Simulation, simulate

    def say(stage: str, done: int = 0, total: int = 0) -> None:
        if progress is not None:
            progress(stage, done, total)

    rig = load_rig()
    sc_path = Path(scenario) if scenario is not None else demo_scenario_path()
    sc_text = sc_path.read_text(encoding="utf-8")
    timings: dict[str, float] = {}
    wd = Path(workdir)
    wd.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    say("simulating the paper's three runs")
    rec = wd / "demo.mcap"
    truth = [wd / f"demo.{k}" for k in ("truth.parquet", "truth-samples.parquet", "truth.json")]
    if reuse and rec.exists() and all(p.exists() for p in truth):
        sim = Simulation(
            recording=rec,
            frames=pl.read_parquet(truth[0]),
            samples=pl.read_parquet(truth[1]),
            scenario=json.loads(truth[2].read_text()),
        )
    else:
        sim = simulate(rig, sc_path, rec)
    timings["simulate"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    say("extracting", 0, sim.recording.stat().st_size)

    def on_bytes(done: int, total: int, frames: int) -> None:
        del frames
        say("extracting", done, total)

    ex = extract(sim.recording, rig, progress=on_bytes)
    spans = (
        pl.concat([sim.frames.select("run", "t_ns"), sim.samples.select("run", "t_ns")])
        .group_by("run", maintain_order=True)
        .agg(lo=pl.col("t_ns").min(), hi=pl.col("t_ns").max())
    )
    runs = [
        run_from_extraction(
            ex,
            rig,
            name=str(name),
            source=f"{sim.recording.name} ({name})",
            window_ns=(int(lo), int(hi)),
            recording=sim.recording.name,
        )
        for name, lo, hi in spans.iter_rows()
    ]
    timings["extract"] = time.perf_counter() - t0
    hours = [(float(hi) - float(lo)) / 3.6e12 for _, lo, hi in spans.iter_rows()]
    intro = (
        "This is thermrs' demo: the paper's runs "
        f"({', '.join(f'{r.name} {h:.1f} h' for r, h in zip(runs, hours, strict=True))}) "
        "simulated on the embedded KR 15/2 rig "
        f"from the scenario {sc_path.name} ({sim.frames.height:,} CCD frames and "
        f"{sim.samples.height:,} thermal frames in one recording of "
        f"{sim.recording.stat().st_size / 1e6:.1f} MB), extracted, cut into its runs at "
        "the scenario's schedule, fitted on the first run and predicting the others, as "
        f"the paper did. {_effects_sentence(sim.scenario)}"
    )
    why = explanation(sc_text)
    if why:
        intro += " " + why
    return DemoRuns(runs=runs, recording=sim.recording, intro=intro, timings=timings)


def run_demo(
    out: str | Path,
    *,
    workdir: str | Path | None = None,
    scenario: str | Path | None = None,
    pdf: bool = False,
    markdown: bool = True,
    progress: DemoProgress | None = None,
) -> DemoResult:
    """Simulate, extract and report the demo (see the module docstring).

    Parameters
    ----------
    out
        The report's HTML file (the Markdown twin beside it).
    workdir
        Where the recording and its truth are kept (default: a temporary folder, removed).
    scenario
        Another scenario file in place of the shipped one.
    pdf
        Also print the report to PDF.
    markdown
        Also write the Markdown twin.
    progress
        Called as ``progress(stage, done, total)``.
    """
    with tempfile.TemporaryDirectory(prefix="thermrs-demo-") as tmp:
        d = simulate_demo(
            workdir if workdir is not None else tmp, scenario=scenario, progress=progress
        )
        steps = iter(range(1, 100))

        def step(what: str) -> None:
            if progress is not None:
                progress(what, next(steps), 0)

        t0 = time.perf_counter()
        written = write_report(
            out,
            runs=d.runs,
            rig=load_rig(),
            title="thermrs demo: the KR 15/2 paper's three runs, simulated",
            intro=d.intro,
            pdf=pdf,
            markdown=markdown,
            paper_reference=True,
            step=step,
        )
        timings = {**d.timings, "report": time.perf_counter() - t0}
    return DemoResult(written=written, recording=d.recording, timings=timings)
