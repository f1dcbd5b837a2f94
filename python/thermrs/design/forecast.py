"""What a candidate's runs would record, from the simulator.

- :func:`forecast_tables`: the visits a protocol would give (times, and the temperatures the
  IR camera would read, from the simulator's thermal model without noise), as run tables with
  no spot (the separation criterion needs only where and when the visits are, and the drivers);
  a new chip's visits come at its base pose's visit times (one cycle visits every pose).
- :func:`simulated_runs`: a scenario simulated on a rig, written as a real recording, extracted
  and cut into its runs at the scenario's schedule: what the proof diagnoses.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np
import polars as pl

from thermrs.design.files import scenario_toml, write_text_atomic
from thermrs.design.measurements import Candidate, Protocol
from thermrs.rig import Rig

__all__ = ["forecast_tables", "simulated_runs", "truth_runs"]


def _protocol_candidate(protocol: Protocol) -> Candidate:
    return Candidate(label=protocol.label, kind="protocol", protocol=protocol)


def protocol_samples(
    rig: Rig, protocol: Protocol, *, cycle_s: float, workdir: Path
) -> tuple[pl.DataFrame, pl.DataFrame]:
    """The protocol simulated on the user's rig without effects: its visit times per camera
    (``run``, ``camera``, ``t_ns``) and its thermal samples (surface temperatures, ambient).
    Only the truth is simulated (no image rendered, no recording written)."""
    from thermrs.simulate import simulate_truth

    slug = "".join(ch if ch.isalnum() else "-" for ch in protocol.label)
    sc = workdir / f"forecast-{slug}.toml"
    text = scenario_toml(
        _protocol_candidate(protocol),
        cycle_s=cycle_s,
        name=f"forecast {protocol.label}",
        extra={"camera": {"frames_per_visit": 1}, "output": {"compression": "none"}},
    )
    write_text_atomic(sc, text)
    sim = simulate_truth(rig, sc)
    return sim.frames.select("run", "camera", "t_ns"), sim.samples


def forecast_tables(
    rig: Rig,
    visits: pl.DataFrame,
    samples: pl.DataFrame,
    *,
    new_camera: str | None = None,
    like_camera: str | None = None,
) -> list[pl.DataFrame]:
    """Run tables of the forecast visits, one per run, with a ``<roi>_c`` column per ROI (the
    surface temperature) and ``ambient_c``; ``new_camera`` visited at ``like_camera``'s times.
    ``u_um``/``v_um`` are the visits' true spots where ``visits`` has them (``x_px``,
    ``y_px``), else zero (no spot)."""
    v = visits
    if new_camera is not None and like_camera is not None:
        extra = v.filter(pl.col("camera") == like_camera).with_columns(
            camera=pl.lit(new_camera), t_ns=pl.col("t_ns") + 1
        )
        v = pl.concat([v, extra])
    out = []
    for run in dict.fromkeys(v["run"].to_list()):
        rv = v.filter(pl.col("run") == run).sort("t_ns")
        rs = samples.filter(pl.col("run") == run).sort("t_ns")
        t = rv["t_ns"].to_numpy().astype(np.float64)
        ts = rs["t_ns"].to_numpy().astype(np.float64)
        u_um, v_um = np.zeros(rv.height), np.zeros(rv.height)
        if "x_px" in rv.columns:  # true spots: chip micrometres about the chip's centre
            for cam in rv["camera"].unique().to_list():
                m = (rv["camera"] == cam).to_numpy()
                xy = rv["x_px"].to_numpy()[m], rv["y_px"].to_numpy()[m]
                u_um[m], v_um[m] = rig.camera(str(cam)).px_to_um(*xy)
        cols: dict[str, object] = {
            "run": rv["run"],
            "camera": rv["camera"],
            "t_ns": rv["t_ns"],
            "u_um": u_um,
            "v_um": v_um,
        }
        for roi in rig.rois:
            c = f"{roi.name}_surface_c"
            if c in rs.columns:
                cols[f"{roi.name}_c"] = np.interp(t, ts, rs[c].to_numpy())
        cols["ambient_c"] = np.interp(t, ts, rs["ambient_c"].to_numpy())
        out.append(pl.DataFrame(cols))
    return out


def _inputs(workdir: Path, stem: str, rig_text: str, scenario_text: str) -> tuple[Path, Path]:
    """The simulation's rig and scenario files, written in ``workdir``."""
    rig_path = workdir / f"{stem}.rig.toml"
    sc_path = workdir / f"{stem}.scenario.toml"
    write_text_atomic(rig_path, rig_text)
    write_text_atomic(sc_path, scenario_text)
    return rig_path, sc_path


def truth_runs(
    rig: Rig,
    sim_rig_text: str,
    scenario_text: str,
    *,
    workdir: Path,
    stem: str,
    seed: int,
    cancel: Callable[[], bool] | None = None,
) -> list[pl.DataFrame]:
    """The runs of ``scenario_text`` on the rig ``sim_rig_text`` as the simulator's truth has
    them (:func:`thermrs.simulate.simulate_truth`): every visit's true spot, where the laser
    met the chip with the robot where it really stood (its pose error in, as in a recording),
    and the links' true surface temperatures; no image rendered, so no centroid noise and no
    reading noise of the temperatures. Run tables in the scenario's order; ``cancel`` as for
    :func:`simulated_runs`."""
    from thermrs.simulate import simulate_truth

    rig_path, sc_path = _inputs(workdir, stem, sim_rig_text, scenario_text)
    sim = simulate_truth(rig_path, sc_path, seed=seed, cancel=cancel)
    frames = sim.frames.filter(pl.col("x_px").is_not_null() & pl.col("y_px").is_not_null())
    return forecast_tables(rig, frames, sim.samples)


def simulated_runs(
    rig: Rig,
    sim_rig_text: str,
    scenario_text: str,
    *,
    workdir: Path,
    stem: str,
    seed: int,
    cancel: Callable[[], bool] | None = None,
) -> list[pl.DataFrame]:
    """Simulate ``scenario_text`` on the rig ``sim_rig_text`` (the truth's rig), extract the
    recording with ``rig`` (the rig the user would analyse it with) and cut it into its runs;
    run tables in the scenario's order. ``cancel()`` true stops it with ``KeyboardInterrupt``
    (as Ctrl-C does in the main thread)."""
    from thermrs.fit import run_table_from
    from thermrs.ingest import extract
    from thermrs.simulate import simulate

    rig_path, sc_path = _inputs(workdir, stem, sim_rig_text, scenario_text)
    rec = workdir / f"{stem}.mcap"
    sim = simulate(rig_path, sc_path, rec, seed=seed, cancel=cancel)

    def check(done: int, total: int, frames: int) -> None:
        del done, total, frames
        if cancel is not None and cancel():
            raise KeyboardInterrupt("cancelled")

    ex = extract(rec, rig, progress=check)
    spans = (
        pl.concat([sim.frames.select("run", "t_ns"), sim.samples.select("run", "t_ns")])
        .group_by("run", maintain_order=True)
        .agg(lo=pl.col("t_ns").min(), hi=pl.col("t_ns").max())
    )
    tables: list[pl.DataFrame] = []
    for name, lo, hi in spans.iter_rows():

        def cut(df: pl.DataFrame, lo: int = lo, hi: int = hi) -> pl.DataFrame:
            return df.filter((pl.col("t_ns") >= lo) & (pl.col("t_ns") <= hi))

        tables.append(run_table_from(cut(ex.visits), cut(ex.temperatures), rig, run=str(name)))
    for p in (rec, *_truth_files(rec)):
        p.unlink(missing_ok=True)
    return tables


def _truth_files(rec: Path) -> Sequence[Path]:
    stem = rec.name[: -len(".mcap")]
    return [rec.with_name(f"{stem}.{k}") for k in ("truth.parquet", "truth-samples.parquet")] + [
        rec.with_name(f"{stem}.truth.json")
    ]
