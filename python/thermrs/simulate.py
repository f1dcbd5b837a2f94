"""The simulator: a rig at work under a scenario, written as a real recording.

The work is Rust (``thermrs-core``'s ``simulate``, ``heat``, ``model``, ``record``): see its
module documentation for the thermal model, the motion and the sensor models. This module
writes the recording atomically and the truth beside it:

- ``OUT.truth.parquet``: per CCD frame ``camera``, ``t_ns``, ``run``, the true ``x_px``,
  ``y_px`` (SPEC §4);
- ``OUT.truth-samples.parquet``: per thermal sample ``t_ns``, ``run``, ``ambient_c`` and per
  node ``<node>_surface_c`` (what the IR camera sees) and ``<node>_structure_c`` (what expands),
  and per expanding DH length (the rig's and an ``unmodelled_length``'s) its true length
  ``<a|d><row>_mm`` with every effect;
- ``OUT.truth.json``: the scenario as simulated (runs, models, effects with parameters).
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import polars as pl

from thermrs import _native
from thermrs.ingest import atomic_tmp, publish, write_parquet_atomic
from thermrs.rig import Rig

__all__ = ["Simulation", "simulate"]


@dataclass(frozen=True)
class Simulation:
    """What :func:`simulate` wrote and the truth behind it."""

    recording: Path
    frames: pl.DataFrame
    samples: pl.DataFrame
    scenario: dict[str, Any]


def simulate(
    rig: Rig, scenario: str | Path, out: str | Path, *, seed: int | None = None
) -> Simulation:
    """Simulate ``scenario`` (a scenario file) on ``rig``, writing the recording to ``out``.

    Raises
    ------
    ScenarioError
        The scenario does not parse or validate (the message names the key).
    InputError
        The scenario does not fit the rig (e.g. an effect names a camera it does not have).
    """
    scenario = Path(scenario)
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = atomic_tmp(out)
    try:
        cols, sc_json = _native.simulate(
            rig._native, scenario.read_text(), str(tmp), source_name=str(scenario), seed=seed
        )
        publish(tmp, out)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    cams = [c.name for c in rig.cameras]
    runs = [r["name"] for r in json.loads(sc_json)["run"]]
    frames = pl.DataFrame(
        {
            "camera": [cams[i] for i in cols["frame_camera"]],
            "t_ns": cols["frame_t_ns"],
            "run": [runs[i] for i in cols["frame_run"]],
            "x_px": cols["frame_x_px"],
            "y_px": cols["frame_y_px"],
        },
        schema_overrides={"camera": pl.String, "run": pl.String, "t_ns": pl.Int64},
    )
    data: dict[str, Any] = {
        "t_ns": cols["sample_t_ns"],
        "run": [runs[i] for i in cols["sample_run"]],
        "ambient_c": cols["sample_ambient_c"],
    }
    for k, name in enumerate(cols["node_names"]):
        data[f"{name}_surface_c"] = cols["surface_c"][:, k]
        data[f"{name}_structure_c"] = cols["structure_c"][:, k]
    for k, name in enumerate(cols["length_names"]):
        data[f"{name}_mm"] = cols["lengths_mm"][:, k]
    samples = pl.DataFrame(data, schema_overrides={"run": pl.String, "t_ns": pl.Int64})
    stem = out.name[: -len(".mcap")] if out.name.endswith(".mcap") else out.name
    write_parquet_atomic(frames, out.with_name(f"{stem}.truth.parquet"))
    write_parquet_atomic(samples, out.with_name(f"{stem}.truth-samples.parquet"))
    doc = json.loads(sc_json)
    json_path = out.with_name(f"{stem}.truth.json")
    tmp_json = atomic_tmp(json_path)
    tmp_json.write_text(json.dumps(doc, indent=2))
    publish(tmp_json, json_path)
    return Simulation(recording=out, frames=frames, samples=samples, scenario=doc)
