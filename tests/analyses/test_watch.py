"""``thermrs.analyses.watch``: a run watched while it is recorded.

A training run and a live run of the paper rig are simulated (the live one with other noise);
the live recording reaches the watched file piece by piece. Checked against the world: the
tables at the end are :func:`thermrs.extract`'s on the finished file; the drift foreseen at
the horizon from the first half of the run covers the drift the simulator's truth has there
(the true spot, not a measurement); a watch stopped half way leaves its tables with its state
and a second watch on the same ``out`` goes on to the same end; the time the drift is foreseen
to leave a tolerance is where the truth leaves it.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import polars as pl
import pytest
import thermrs
from polars.testing import assert_frame_equal
from thermrs.analyses.watch import read_partial, watch
from thermrs.follow import STATE_KEY

TABLES = ("frames", "visits", "temperatures", "joints", "runs")

SCENARIO = """format = "thermrs-scenario/1"
name = "one run at 75 %"
seed = {seed}
[[run]]
name = "r75"
speed_pct = 75
duration_min = 240
cycle_s = 300
start = "ambient"
[camera]
mode = "visits"
frames_per_visit = 1
[output]
compression = "zstd"
"""


@dataclass(frozen=True)
class Runs:
    train: pl.DataFrame
    live: Path
    truth: pl.DataFrame


@pytest.fixture(scope="module")
def runs(tmp_path_factory: pytest.TempPathFactory) -> Runs:
    d = tmp_path_factory.mktemp("watch")
    rig = thermrs.default_rig_path()
    recs = {}
    for name, seed in (("train", 21), ("live", 22)):
        sc = d / f"{name}.toml"
        sc.write_text(SCENARIO.format(seed=seed))
        recs[name] = thermrs.simulate.simulate(rig, sc, d / f"{name}.mcap").recording
    train = thermrs.runs.load_runs(recs["train"], rig).tables[0]
    truth = pl.read_parquet(d / "live.truth.parquet")
    return Runs(train, recs["live"], truth)


class Drip:
    """The recorder: ``sleep`` appends the next piece of the finished file's bytes."""

    def __init__(self, src: Path, dst: Path, pieces: int) -> None:
        self.data = src.read_bytes()
        self.dst = dst
        self.piece = len(self.data) // pieces + 1
        self.pos = 0
        dst.write_bytes(b"")

    def __call__(self, _s: float) -> None:
        with self.dst.open("ab") as fh:
            fh.write(self.data[self.pos : self.pos + self.piece])
        self.pos += self.piece


def _true_drift_um(truth: pl.DataFrame, rig: thermrs.Rig) -> dict[tuple[str, str], float]:
    """The truth's drift from each camera's first visit to its last (chip µm)."""
    out = {}
    for cam in rig.cameras:
        g = truth.filter(pl.col("camera") == cam.name).sort("t_ns")
        out[(cam.name, "u")] = float(g["x_px"][-1] - g["x_px"][0]) * cam.pixel_pitch_um[0]
        out[(cam.name, "v")] = float(g["y_px"][-1] - g["y_px"][0]) * cam.pixel_pitch_um[1]
    return out


def test_watched_to_the_end(tmp_path: Path, runs: Runs, paper_rig: thermrs.Rig) -> None:
    live = tmp_path / "live.mcap"
    drip = Drip(runs.live, live, pieces=24)
    out = tmp_path / "out.parquet"
    updates = list(watch(live, paper_rig, train=[runs.train], out=out, sleep=drip, poll_s=0))
    assert updates[-1].closed and not any(u.closed for u in updates[:-1])
    ref = thermrs.extract(runs.live, paper_rig)
    ref_out = tmp_path / "ref.parquet"
    ref.write(ref_out)
    for t in TABLES:
        got = out if t == "frames" else tmp_path / f"out.{t}.parquet"
        want = ref_out if t == "frames" else tmp_path / f"ref.{t}.parquet"
        assert_frame_equal(pl.read_parquet(got), pl.read_parquet(want), check_exact=True)
        assert STATE_KEY not in pl.read_parquet_metadata(got)
    # Each update read only what was added: the bytes add up to the data section once.
    assert sum(u.step.bytes_read for u in updates) == updates[-1].bytes_read
    # The outlook from about half the run covers the truth at the end.
    mid = next(u for u in updates if u.hours >= 2.0 and u.outlook is not None)
    truth = _true_drift_um(runs.truth, paper_rig)
    o = mid.outlook
    assert o is not None and o.horizon_h == pytest.approx(4.0, abs=0.1)
    for r in o.crossings.iter_rows(named=True):
        want = truth[(r["camera"], r["axis"])]
        assert r["end_lo_um"] <= want <= r["end_hi_um"], (r, want)


def test_stopped_and_resumed(tmp_path: Path, runs: Runs, paper_rig: thermrs.Rig) -> None:
    live = tmp_path / "live.mcap"
    drip = Drip(runs.live, live, pieces=12)
    out = tmp_path / "out.parquet"
    first = watch(live, paper_rig, out=out, sleep=drip, poll_s=0)
    for _, _u in zip(range(5), first, strict=False):
        pass
    first.close()  # the caller stops taking updates: the tables so far, with the state
    part = read_partial(out)
    assert part is not None
    ex, state = part
    assert 0 < state["bytes"] < runs.live.stat().st_size
    assert ex.frames.height > 0
    second = list(watch(live, paper_rig, out=out, sleep=drip, poll_s=0))
    assert second[-1].closed
    # It went on where the first stopped: nothing before read again.
    assert second[0].bytes_read == state["bytes"] and second[0].step.bytes_read == 0
    ref = thermrs.extract(runs.live, paper_rig)
    for t in TABLES:
        got = out if t == "frames" else tmp_path / f"out.{t}.parquet"
        assert_frame_equal(pl.read_parquet(got), getattr(ref, t), check_exact=True)


def test_until_on_a_recording_never_closed(
    tmp_path: Path, runs: Runs, paper_rig: thermrs.Rig
) -> None:
    data = runs.live.read_bytes()
    live = tmp_path / "killed.mcap"
    live.write_bytes(data[: len(data) * 2 // 3 + 7])  # killed mid-record, no footer ever
    ticks = iter(range(1000))
    out = tmp_path / "out.parquet"
    updates = list(
        watch(
            live,
            paper_rig,
            out=out,
            until_s=3,
            sleep=lambda s: None,
            clock=lambda: float(next(ticks)),
        )
    )
    last = updates[-1]
    assert not last.closed
    assert last.extraction is not None and last.extraction.report.losses == []
    assert read_partial(out) is not None


def test_the_tolerance_is_left_where_the_truth_leaves_it(
    runs: Runs, paper_rig: thermrs.Rig, tmp_path: Path
) -> None:
    """A tolerance the truth crosses in the run's second half: foreseen from its first."""
    truth = runs.truth.filter(pl.col("camera") == "A").sort("t_ns")
    cam = paper_rig.camera("A")
    v = (truth["y_px"] - truth["y_px"][0]).to_numpy() * cam.pixel_pitch_um[1]
    u = (truth["x_px"] - truth["x_px"][0]).to_numpy() * cam.pixel_pitch_um[0]
    h = (truth["t_ns"] - truth["t_ns"][0]).to_numpy() / 3.6e12
    axis, series = max((("u", u), ("v", v)), key=lambda a: abs(a[1][-1]))
    tol = 0.8 * abs(series[-1])
    crossed = float(h[np.argmax(np.abs(series) > tol)])
    assert crossed > 2.0  # in the second half of the run
    live = tmp_path / "live.mcap"
    drip = Drip(runs.live, live, pieces=24)
    mid = next(
        u
        for u in watch(live, paper_rig, train=[runs.train], tolerance_um=tol, sleep=drip, poll_s=0)
        if u.hours >= 1.5 and u.outlook is not None
    )
    assert mid.outlook is not None
    row = mid.outlook.crossings.filter((pl.col("camera") == "A") & (pl.col("axis") == axis))
    lo, hi = row["leaves_lo_h"].item(), row["leaves_hi_h"].item()
    assert lo is not None and lo <= crossed and (hi is None or crossed <= hi)


def test_the_sequential_diagnosis_and_the_finished_runs(
    tmp_path: Path, runs: Runs, paper_rig: thermrs.Rig
) -> None:
    """With training runs the watch looks every 2 h (one error budget over the looks) and,
    once the recording closes, gives the diagnosis `thermrs diagnose` gives on the finished
    file (the same runs, options and seed)."""
    from thermrs.diagnose import diagnose

    live = tmp_path / "live.mcap"
    drip = Drip(runs.live, live, pieces=12)
    updates = list(
        watch(live, paper_rig, train=[runs.train], sleep=drip, poll_s=0, look_every_h=2.0)
    )
    looks = [u.look for u in updates if u.look is not None]
    assert looks, "no look was taken"
    spent = [lk.level_spent for lk in dict.fromkeys(looks)]
    assert all(b > a for a, b in itertools.pairwise(spent)) and spent[-1] <= 0.05
    final = updates[-1].diagnosis
    assert final is not None
    held = thermrs.runs.load_runs(runs.live, paper_rig).tables
    want = diagnose([runs.train], held, paper_rig)
    assert final.outcome == want.outcome
    assert final.to_json()["verdict"] == want.to_json()["verdict"]
