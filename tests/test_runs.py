"""Runs inside recordings: run markers, idle-gap splitting, drift anchored per run, and the
paper's protocol (fit on run 1, predict runs 2 and 3 of one recording) through the CLI.

The truth is the simulator's own record of which run each CCD frame belongs to and where its
spot really was (``OUT.truth.parquet``), which extraction never reads."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import polars as pl
import pytest
import thermrs
from thermrs.errors import InputError
from thermrs.runs import (
    RUNS_SCHEMA,
    label_runs,
    load_runs,
    runs_from_gaps,
    runs_from_markers,
    split_run_spec,
)
from thermrs.simulate import simulate

# The paper's three runs (fixtures/scenarios/paper-runs.toml), shortened: run 1 from ambient,
# an idle cool-down, run 2 at 75 %, run 3 straight after it.
SCENARIO = """format = "thermrs-scenario/1"
seed = 2008
[[run]]
name = "run1"
speed_pct = 30
duration_min = 45
cycle_s = 60
start = "ambient"
[[run]]
name = "run2"
speed_pct = 75
duration_min = 45
cycle_s = 60
start = "continue"
idle_before_min = 90
[[run]]
name = "run3"
speed_pct = 10
duration_min = 45
cycle_s = 60
start = "continue"
[camera]
mode = "visits"
frames_per_visit = 2
[output]
compression = "zstd"
"""


def visits(times_s: list[float]) -> pl.DataFrame:
    """Visits of cameras A and B at the given times (B 20 s after A), 5 s long."""
    rows = []
    for cam, lag in (("A", 0.0), ("B", 20.0)):
        for t in times_s:
            t0 = int((t + lag) * 1e9)
            rows.append({"camera": cam, "t_start_ns": t0, "t_end_ns": t0 + 5 * 10**9})
    return pl.DataFrame(rows)


def test_idle_gap_splits_and_short_pauses_do_not() -> None:
    first = [60.0 * k for k in range(30)]
    second = [first[-1] + 7200 + 60.0 * k for k in range(30)]
    runs = runs_from_gaps(visits(first + second))
    assert runs["run"].to_list() == ["run1", "run2"]
    assert runs["source"].to_list() == ["gap", "gap"]
    assert runs["start_ns"][0] == 0 and runs["start_ns"][1] == int(second[0] * 1e9)
    # Run 1 ends one cadence after its last visit.
    assert runs["end_ns"][0] == int((first[-1] + 20 + 5) * 1e9) + 60 * 10**9
    # An 8-minute pause is more than 5 cadences but under the 10-minute floor: one run,
    # unless the floor is lowered.
    paused = first + [first[-1] + 480 + 60.0 * k for k in range(10)]
    assert runs_from_gaps(visits(paused)).height == 1
    assert runs_from_gaps(visits(paused), min_gap_s=0).height == 2
    assert runs_from_gaps(visits(first)).height == 1


def test_labels_are_strings_whatever_lies_outside_the_runs() -> None:
    """A stamp outside every run (the first joint state, before the first visit) is null,
    first or not; overlapping runs give the later one; no run at all: every label null."""
    runs = pl.DataFrame(
        [{"run": "a", "start_ns": 10, "end_ns": 30, "source": "gap"},
         {"run": "b", "start_ns": 25, "end_ns": 50, "source": "gap"}],
        schema=RUNS_SCHEMA,
    )  # fmt: skip
    stamps = [0, 10, 26, 50, 51]
    for t in (stamps, stamps[::-1], [0], [], [None, 10]):
        got = label_runs(pl.Series(t, dtype=pl.Int64), runs)
        assert got.dtype == pl.String and got.name == "run"
        want = [None if x is None or not 10 <= x <= 50 else "a" if x < 25 else "b" for x in t]
        assert got.to_list() == want
    assert label_runs(np.array(stamps), runs).to_list() == [None, "a", "b", "b", None]
    none = label_runs(np.array(stamps), pl.DataFrame(schema=RUNS_SCHEMA))
    assert none.dtype == pl.String and none.null_count() == len(stamps)


def test_marker_errors_name_the_marker() -> None:
    good = {"name": "thermrs.run", "values": {"name": "a", "start_ns": "1", "end_ns": "5"}}
    other = {"name": "something.else", "values": {}}
    assert runs_from_markers([other, good])["run"].to_list() == ["a"]
    bad = {"name": "thermrs.run", "values": {"name": "b", "start_ns": "x", "end_ns": "5"}}
    with pytest.raises(InputError, match="run marker 2"):
        runs_from_markers([good, bad])
    with pytest.raises(InputError, match="marked more than once"):
        runs_from_markers([good, good])
    backwards = {"name": "thermrs.run", "values": {"name": "c", "start_ns": "9", "end_ns": "5"}}
    with pytest.raises(InputError, match="before start_ns"):
        runs_from_markers([backwards])


def test_run_spec() -> None:
    assert split_run_spec("dir/rec.mcap#run2") == (Path("dir/rec.mcap"), "run2")
    assert split_run_spec("rec.mcap") == (Path("rec.mcap"), None)
    with pytest.raises(InputError, match="no run name"):
        split_run_spec("rec.mcap#")


@pytest.fixture(scope="module")
def recording(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, pl.DataFrame]:
    d = tmp_path_factory.mktemp("runs")
    (d / "paper3.toml").write_text(SCENARIO)
    sim = simulate(thermrs.load_rig(), d / "paper3.toml", d / "x.mcap")
    return sim.recording, sim.frames


def strip_markers(src: Path, dst: Path) -> None:
    """Copy a recording message by message without its Metadata records (the `mcap` library,
    not thermrs): what a recorder that knows nothing of run markers writes."""
    from mcap.reader import make_reader
    from mcap.writer import CompressionType, Writer

    with src.open("rb") as f, dst.open("wb") as g:
        reader = make_reader(f)
        w = Writer(g, compression=CompressionType.ZSTD)
        w.start(profile=reader.get_header().profile, library="test")
        schemas: dict[int, int] = {}
        channels: dict[int, int] = {}
        for schema, channel, msg in reader.iter_messages(log_time_order=False):
            assert schema is not None
            if schema.id not in schemas:
                schemas[schema.id] = w.register_schema(schema.name, schema.encoding, schema.data)
            if channel.id not in channels:
                channels[channel.id] = w.register_channel(
                    channel.topic, channel.message_encoding, schemas[schema.id], channel.metadata
                )
            w.add_message(
                channels[channel.id], msg.log_time, msg.data, msg.publish_time, msg.sequence
            )
        w.finish()


def truth_run_of_visits(ex: thermrs.Extraction, truth: pl.DataFrame) -> list[str]:
    """Per visit, the run the simulator says its frames belong to."""
    t = truth.sort("t_ns").select("camera", "t_ns", pl.col("run").alias("truth_run"))
    v = ex.visits.sort("t_ns").join_asof(t, on="t_ns", by="camera", check_sortedness=False)
    return v["truth_run"].to_list()


def test_markers_give_runs_and_drift_is_anchored_per_run(
    recording: tuple[Path, pl.DataFrame], paper_rig: thermrs.Rig
) -> None:
    rec, truth = recording
    ex = thermrs.extract(rec, paper_rig)
    assert ex.runs["run"].to_list() == ["run1", "run2", "run3"]
    assert set(ex.runs["source"].to_list()) == {"marker"}
    v = ex.visits.sort("t_ns")
    assert v["run"].to_list() == truth_run_of_visits(ex, truth)
    # Drift: from each camera's first visit in its run, as the true spot moved.
    cams = {c.name: c for c in paper_rig.cameras}
    tr = truth.with_columns(
        u_true=(pl.col("x_px") - pl.col("camera").replace_strict(
            {n: (c.size_px[0] - 1) / 2 for n, c in cams.items()}, return_dtype=pl.Float64
        )) * pl.col("camera").replace_strict(
            {n: c.pixel_pitch_um[0] for n, c in cams.items()}, return_dtype=pl.Float64
        )
    )  # fmt: skip
    for (run, cam), g in v.group_by("run", "camera"):
        g = g.sort("t_ns")
        assert g["drift_u_um"][0] == 0.0 and g["drift_v_um"][0] == 0.0
        f = tr.filter((pl.col("run") == run) & (pl.col("camera") == cam)).sort("t_ns")
        true_u = np.interp(g["t_ns"].to_numpy(), f["t_ns"].to_numpy(), f["u_true"].to_numpy())
        true_drift = true_u - true_u[0]
        assert np.max(np.abs(g["drift_u_um"].to_numpy() - true_drift)) < 2.0, (run, cam)


@pytest.mark.slow
@pytest.mark.floors
def test_without_markers_the_idle_gap_splits(
    recording: tuple[Path, pl.DataFrame], paper_rig: thermrs.Rig, tmp_path: Path
) -> None:
    """The same recording copied without its run markers: the 90-minute cool-down splits it;
    runs 2 and 3 follow each other without a pause, so they stay one run."""
    rec, truth = recording
    bare = tmp_path / "bare.mcap"
    strip_markers(rec, bare)
    ex = thermrs.extract(bare, paper_rig)
    assert ex.report.metadata == []
    assert ex.runs["run"].to_list() == ["run1", "run2"]
    assert set(ex.runs["source"].to_list()) == {"gap"}
    want = ["run1" if r == "run1" else "run2" for r in truth_run_of_visits(ex, truth)]
    assert ex.visits.sort("t_ns")["run"].to_list() == want


def cli(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "thermrs", *args], capture_output=True, text=True)


@pytest.mark.slow
def test_paper_protocol_through_the_cli(
    recording: tuple[Path, pl.DataFrame], tmp_path: Path
) -> None:
    """Simulate the three runs into one recording, fit α on run 1, predict runs 2 and 3."""
    rec, _ = recording
    rig = str(thermrs.default_rig_path())
    fit_json = tmp_path / "fit.json"
    r = cli("fit", "--rig", rig, "--train", f"{rec}#run1", "--json", str(fit_json))
    assert r.returncode == 0, r.stderr
    assert "3 runs (run markers): run1" in r.stderr and "using x#run1" in r.stderr
    doc = json.loads(fit_json.read_text())
    assert doc["n_visits"] == 2 * 45  # run 1 only: one visit per camera per minute
    lo, hi = doc["alpha_per_k"]["ci95"]
    assert 0.9 * 23.2e-6 < doc["alpha_per_k"]["value"] < 1.1 * 23.2e-6
    assert lo < doc["alpha_per_k"]["value"] < hi and doc["interval"] and doc["n_eff"] > 1
    pred_json = tmp_path / "pred.json"
    r = cli(
        "predict", "--rig", rig, "--train", f"{rec}#run1",
        "--run", f"{rec}#run2", f"{rec}#run3", "--json", str(pred_json),
    )  # fmt: skip
    assert r.returncode == 0, r.stderr
    table = json.loads(pred_json.read_text())["table"]
    assert {row["run"] for row in table} == {"x#run2", "x#run3"}
    # A file without '#': every run of it; an unknown run: exit 2 naming the runs there are.
    r = cli("drift", "--rig", rig, "--run", str(rec))
    assert r.returncode == 0, r.stderr
    assert "using x#run1, x#run2, x#run3" in r.stderr
    r = cli("fit", "--rig", rig, "--train", f"{rec}#run7")
    assert r.returncode == 2
    assert "no run 'run7'" in r.stderr and "run1, run2, run3" in r.stderr


def test_extracted_tables_carry_the_runs(
    recording: tuple[Path, pl.DataFrame], paper_rig: thermrs.Rig, tmp_path: Path
) -> None:
    rec, _ = recording
    out = tmp_path / "x.parquet"
    r = cli("extract", str(rec), "--rig", str(thermrs.default_rig_path()), "-o", str(out))
    assert r.returncode == 0, r.stderr
    assert pl.read_parquet(tmp_path / "x.runs.parquet")["run"].to_list() == [
        "run1",
        "run2",
        "run3",
    ]
    from_tables = load_runs(f"{tmp_path / 'x.visits.parquet'}#run2", paper_rig).tables[0]
    from_rec = load_runs(f"{rec}#run2", paper_rig).tables[0]
    assert from_tables.equals(from_rec)


def test_visits_after_the_last_marker_are_not_dropped() -> None:
    """A recording cut short before its last run's marker: the unmarked visits form a run of
    their own."""
    from thermrs.runs import find_runs

    first = [60.0 * k for k in range(30)]
    second = [first[-1] + 7200 + 60.0 * k for k in range(30)]
    v = visits(first + second).with_columns(t_ns=pl.col("t_start_ns"))
    marker = {
        "name": "thermrs.run",
        "values": {"name": "run1", "start_ns": "0", "end_ns": str(int((first[-1] + 60) * 1e9))},
    }
    runs = find_runs([marker], v)
    assert runs["run"].to_list() == ["run1", "unmarked1"]
    assert runs["source"].to_list() == ["marker", "gap"]
    assert runs["start_ns"][1] == int(second[0] * 1e9)
