"""``thermrs simulate``: a rig at work under a scenario, written as a recording."""

from __future__ import annotations

import time
from pathlib import Path

import click

from thermrs.cli.common import (
    console,
    input_file,
    out_option,
    rig_option,
    writable,
)


@click.command()
@rig_option
@click.option(
    "--scenario",
    "scenario_path",
    required=True,
    type=input_file,
    help="Scenario file (thermrs-scenario/1; see docs/scenarios.md).",
)
@out_option("Recording to write (OUT.mcap, in an existing folder); the truth is written beside it.")
@click.option(
    "--seed",
    type=click.IntRange(min=0, max=2**64 - 1),
    default=None,
    help="Override the scenario's seed (0 ≤ N < 2⁶⁴).",
)
def simulate(rig_path: Path, scenario_path: Path, out_path: Path, seed: int | None) -> None:
    """Simulate a rig at work: write a recording in the rig's own format and its truth
    (OUT.truth.parquet, OUT.truth-samples.parquet, OUT.truth.json)."""
    from thermrs.rig import load_rig
    from thermrs.simulate import simulate as run_simulate

    writable(out_path, "-o", suffixes=(".mcap",))
    r = load_rig(rig_path)
    t0 = time.perf_counter()
    sim = run_simulate(r, scenario_path, out_path, seed=seed)
    dt = time.perf_counter() - t0
    err = console(stderr=True)
    size = sim.recording.stat().st_size / 1e6
    err.print(
        f"wrote {sim.recording} ({size:,.1f} MB): {sim.frames.height:,} CCD frames, "
        f"{sim.samples.height:,} thermal samples in {dt:.1f} s"
    )
