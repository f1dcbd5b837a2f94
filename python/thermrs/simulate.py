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

:func:`simulate_truth` gives the same truth without the recording (no pixel rendered, nothing
written): what a forecast of visit times and temperatures needs, at a small fraction of the
cost.
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import polars as pl

import thermrs._native as _native
from thermrs.atomic import write_atomic, write_json, write_parquet_atomic
from thermrs.errors import InputError
from thermrs.rig import Rig, as_rig

__all__ = ["SimulatedTruth", "Simulation", "simulate", "simulate_truth"]


@dataclass(frozen=True)
class SimulatedTruth:
    """The truth of a simulation (:func:`simulate_truth`): per CCD frame the true spot, per
    thermal sample the temperatures and expanded lengths, and the scenario as simulated."""

    frames: pl.DataFrame
    samples: pl.DataFrame
    scenario: dict[str, Any]


@dataclass(frozen=True)
class Simulation:
    """What :func:`simulate` wrote and the truth behind it."""

    recording: Path
    frames: pl.DataFrame
    samples: pl.DataFrame
    scenario: dict[str, Any]


def simulate(
    rig: Rig | str | os.PathLike[str],
    scenario: str | os.PathLike[str],
    out: str | os.PathLike[str],
    *,
    seed: int | None = None,
    cancel: Callable[[], bool] | None = None,
) -> Simulation:
    """Simulate ``scenario`` (a scenario file) on ``rig``, writing the recording to ``out``.

    The scenario format (runs, ambient, camera and IR models, thermal nodes, SPEC §6
    effects) is documented in ``docs/scenarios.md``; examples ship in
    ``fixtures/scenarios/``.

    Parameters
    ----------
    rig
        The rig to simulate (a :class:`~thermrs.Rig` or the path of a rig file).
    scenario
        The scenario file (``format = "thermrs-scenario/1"``).
    out
        The recording to write (MCAP, atomically); its folder must exist. The truth goes
        beside it: ``OUT.truth.parquet``, ``OUT.truth-samples.parquet``, ``OUT.truth.json``.
    seed
        Overrides the scenario's seed (0 ≤ seed < 2⁶⁴); the same seed gives the same bytes.
    cancel
        Asked every few milliseconds; once it returns true the simulation stops as on Ctrl-C
        (signals reach only the main thread: this stops a simulation in another thread).

    Returns
    -------
    Simulation
        The recording's path and the truth: per CCD frame the true spot, per thermal sample
        the surface and structure temperatures and expanded lengths, and the scenario.

    Raises
    ------
    ScenarioError
        The scenario does not parse or validate (the message names the line and key).
    InputError
        The scenario file cannot be read; ``out``'s folder does not exist; the scenario does
        not fit the rig (e.g. an effect names a camera it does not have); ``seed`` is out of
        range.
    OutputError
        The recording cannot be written (a read-only folder, a full disk): an ``OSError``
        naming ``out`` with the system's errno; nothing is left behind.
    KeyboardInterrupt
        Ctrl-C (checked every few milliseconds), or ``cancel()`` true; nothing is left behind.

    Examples
    --------
    >>> import thermrs
    >>> sim = thermrs.simulate.simulate(
    ...     thermrs.load_rig(), "fixtures/scenarios/two-runs-thermal-lag.toml", "sim.mcap"
    ... )  # doctest: +SKIP
    >>> sim.frames.select("camera", "t_ns", "x_px", "y_px")  # doctest: +SKIP
    """
    rig = as_rig(rig)
    scenario = Path(scenario)
    out = Path(out)
    text = _read_scenario(rig, scenario, seed)
    result: list[Any] = []

    def record(tmp: Path) -> None:  # a failed write names the file asked for, not the temporary
        result.extend(
            _native.simulate(
                rig._native, text, str(tmp), source_name=str(scenario), seed=seed, cancel=cancel
            )
        )

    write_atomic(out, record)
    truth = _truth(rig, *result)
    frames, samples = truth.frames, truth.samples
    stem = out.name[: -len(".mcap")] if out.name.endswith(".mcap") else out.name
    write_parquet_atomic(frames, out.with_name(f"{stem}.truth.parquet"))
    write_parquet_atomic(samples, out.with_name(f"{stem}.truth-samples.parquet"))
    doc = truth.scenario
    write_json(out.with_name(f"{stem}.truth.json"), doc)
    return Simulation(recording=out, frames=frames, samples=samples, scenario=doc)


def simulate_truth(
    rig: Rig | str | os.PathLike[str],
    scenario: str | os.PathLike[str],
    *,
    seed: int | None = None,
    cancel: Callable[[], bool] | None = None,
) -> SimulatedTruth:
    """The truth :func:`simulate` would give, without the recording: the same runs, motion
    and thermal state, so the same truth to the last bit (every sensor draws from its own
    random stream), but no pixel rendered and nothing written.

    Parameters
    ----------
    rig
        The rig to simulate (a :class:`~thermrs.Rig` or the path of a rig file).
    scenario
        The scenario file (``format = "thermrs-scenario/1"``).
    seed
        Overrides the scenario's seed (0 ≤ seed < 2⁶⁴).
    cancel
        As for :func:`simulate`.

    Returns
    -------
    SimulatedTruth
        Per CCD frame the true spot, per thermal sample the temperatures and lengths, and
        the scenario as simulated (as :class:`Simulation`, without a recording).

    Raises
    ------
    ScenarioError
        The scenario does not parse or validate.
    InputError
        The scenario file cannot be read or does not fit the rig; ``seed`` is out of range.
    KeyboardInterrupt
        Ctrl-C, or ``cancel()`` true.

    Examples
    --------
    >>> import thermrs
    >>> t = thermrs.simulate.simulate_truth(
    ...     thermrs.load_rig(), "fixtures/scenarios/two-runs-thermal-lag.toml"
    ... )  # doctest: +SKIP
    >>> t.samples.select("t_ns", "run", "ambient_c")  # doctest: +SKIP
    """
    rig = as_rig(rig)
    scenario = Path(scenario)
    text = _read_scenario(rig, scenario, seed)
    return _truth(
        rig,
        *_native.simulate(
            rig._native, text, None, source_name=str(scenario), seed=seed, cancel=cancel
        ),
    )


def _read_scenario(rig: Rig, scenario: Path, seed: int | None) -> str:
    """The scenario's text, checked as far as Python checks it."""
    if seed is not None and not (isinstance(seed, int) and 0 <= seed < 2**64):
        raise InputError(f"seed must be an integer 0 ≤ seed < 2**64, got {seed!r}")
    if scenario.is_dir():
        raise InputError(f"scenario {scenario}: is a directory, expected a scenario file")
    try:
        text = scenario.read_text()
    except FileNotFoundError:
        raise InputError(f"scenario {scenario}: no such file") from None
    except UnicodeDecodeError:
        raise InputError(
            f"scenario {scenario}: not a text file; a scenario is TOML (docs/scenarios.md)"
        ) from None
    except OSError as e:
        raise InputError(f"scenario {scenario}: cannot read it ({e.strerror or e})") from None
    check_default_nodes(text, scenario, rig)
    return text


def _truth(rig: Rig, cols: dict[str, Any], sc_json: str) -> SimulatedTruth:
    """The native simulator's truth columns as tables."""
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
    return SimulatedTruth(frames=frames, samples=samples, scenario=json.loads(sc_json))


#: The thermal nodes a scenario without ``[[node]]`` gets, those of them the rig has ROIs for:
#: the paper rig's calibrated links and base.
DEFAULT_NODES = ("link2", "link3", "base")


def check_default_nodes(text: str, scenario: str | Path, rig: Rig) -> None:
    """A scenario without ``[[node]]`` is simulated with the paper rig's calibrated nodes of
    the ROIs the rig shares with it (:data:`DEFAULT_NODES`); a rig with a ROI none of them
    covers is refused in the user's terms, naming the ROIs and the fix.

    Parameters
    ----------
    text
        The scenario's TOML.
    scenario
        Its name in messages.
    rig
        The rig it is simulated on.

    Raises
    ------
    InputError
        No ``[[node]]`` and a ROI of the rig without a default node.
    """
    import tomllib

    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError:
        return  # the core names the line
    rois = [r.name for r in rig.rois]
    uncovered = [r for r in rois if r not in DEFAULT_NODES]
    if "node" not in doc and uncovered:
        raise InputError(
            f"scenario {scenario}: no [[node]] given, so the paper rig's thermal nodes "
            f"({', '.join(DEFAULT_NODES)}) are assumed, but rig {Path(rig.source).name} has the "
            f"ROIs {', '.join(rois)}, of which {', '.join(uncovered)} has no such node: add "
            "one [[node]] per ROI (docs/scenarios.md)"
        )
