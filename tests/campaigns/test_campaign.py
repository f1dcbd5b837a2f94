"""Campaigns on a real Dask ``LocalCluster`` of worker processes: the dataset and catalog
against single-file extraction of each recording, a worker killed mid-campaign, resuming after
an interruption, skipping what is already extracted, and the CLI."""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import polars as pl
import pytest
import thermrs
from polars.testing import assert_frame_equal
from thermrs.simulate import simulate

from tests.support.cli import interruptible

SCENARIO = """format = "thermrs-scenario/1"
seed = 2008
[[run]]
name = "run1"
speed_pct = 30
duration_min = 15
cycle_s = 60
start = "ambient"
[[run]]
name = "run2"
speed_pct = 75
duration_min = 15
cycle_s = 60
start = "continue"
idle_before_min = 30
[camera]
mode = "visits"
frames_per_visit = 2
[output]
compression = "zstd"
"""


@pytest.fixture(scope="module")
def recordings(tmp_path_factory: pytest.TempPathFactory) -> list[Path]:
    """Six recordings of two runs each (different seeds: different bytes and drifts)."""
    d = tmp_path_factory.mktemp("campaign")
    (d / "s.toml").write_text(SCENARIO)
    (d / "recs").mkdir()
    rig = thermrs.load_rig()
    return [
        simulate(rig, d / "s.toml", d / "recs" / f"r{i}.mcap", seed=i).recording
        for i in range(1, 7)
    ]


@pytest.fixture(scope="module")
def one_recording(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """One recording of the scenario (seed 1), for the tests that need no more."""
    d = tmp_path_factory.mktemp("campaign-one")
    (d / "s.toml").write_text(SCENARIO)
    return simulate(thermrs.load_rig(), d / "s.toml", d / "r1.mcap", seed=1).recording


@pytest.fixture(scope="module")
def client() -> Iterator[Any]:
    from distributed import Client
    from thermrs.campaigns.engine import local_cluster

    with local_cluster(2) as cluster, Client(cluster) as c:
        yield c


def _pools() -> tuple[int, str | None]:
    import polars as pl

    return pl.thread_pool_size(), os.environ.get("RAYON_NUM_THREADS")


@pytest.mark.slow
def test_workers_of_the_local_cluster_run_one_thread_each(client: Any) -> None:
    """Each worker is one process on one core: polars' own pool and the core's rayon pool
    hold one thread there (as polars itself reports), whatever the machine's cores."""
    for pools in client.run(_pools).values():
        assert pools == (1, "1")


def _background(dask_worker: Any) -> tuple[float, bool, float]:
    pcs = dask_worker.periodic_callbacks
    return dask_worker._tick_interval, "profile" in pcs, pcs["monitor"].callback_time


def _scheduler_tick(dask_scheduler: Any) -> float:
    return float(dask_scheduler._tick_interval)


@pytest.mark.slow
def test_the_local_cluster_keeps_its_background_work_down(client: Any) -> None:
    """The cluster thermrs starts runs its workers' and scheduler's event-loop tick every
    second, no statistical profiler and the system monitor every 2 s (what each process's
    own Dask server reports); the campaign's Dask settings are not left behind in the
    client's process."""
    import dask

    for tick, profiler, monitor_ms in client.run(_background).values():
        assert (tick, profiler, monitor_ms) == (1.0, False, 2000.0)
    assert client.run_on_scheduler(_scheduler_tick) == 1.0
    assert dask.config.get("distributed.worker.profile.enabled") is True


def check_against_single_files(res: Any, recordings: list[Path]) -> None:
    """Catalog and data of the campaign equal each recording's own extraction: every
    recording once, nothing lost, nothing twice."""
    from blake3 import blake3

    rig = thermrs.load_rig()
    cat = res.catalog
    assert sorted(cat["path"].to_list()) == sorted(str(p.resolve()) for p in recordings)
    assert cat["recording"].is_unique().all()
    frames = res.dataset.scan("frames").collect()
    visits = res.dataset.scan("visits").collect()
    assert frames.height == sum(cat["frames"]) and visits.height == sum(cat["visits"])
    for p in recordings:
        ex = thermrs.extract(p, rig)
        row = cat.filter(pl.col("path") == str(p.resolve())).row(0, named=True)
        assert row["content_hash"] == blake3(p.read_bytes()).hexdigest()
        assert (row["frames"], row["visits"], row["runs"]) == (
            ex.frames.height,
            ex.visits.height,
            ex.runs.height,
        )
        assert row["losses"] == 0 and row["robot"] == rig.model
        assert row["thermrs_version"] == thermrs.__version__
        mine = pl.col("recording") == row["recording"]
        got = frames.filter(mine).drop("recording", "run").sort("camera", "t_ns")
        assert_frame_equal(got.select(ex.frames.columns), ex.frames.sort("camera", "t_ns"))
        got_v = visits.filter(mine).drop("recording").sort("camera", "t_start_ns")
        assert_frame_equal(got_v.select(ex.visits.columns), ex.visits.sort("camera", "t_start_ns"))
        runs = res.dataset.scan("runs").filter(mine).collect().sort("start_ns")
        assert runs["run"].to_list() == ex.runs["run"].to_list()


@pytest.mark.slow
def test_the_largest_recordings_run_first(recordings: list[Path], tmp_path: Path) -> None:
    """On one worker, recordings are extracted in the order the scheduler hands them out:
    largest file first (so that a long recording listed last does not run alone at the
    end), whatever the order they were named in."""
    from distributed import Client
    from thermrs.campaigns.engine import local_cluster

    named = sorted(recordings, key=lambda p: p.stat().st_size)  # smallest first
    assert len({p.stat().st_size for p in named}) == len(named)
    with local_cluster(1) as cluster, Client(cluster) as c:
        res = thermrs.campaign(named, tmp_path / "ds", client=c)
    assert res.extracted == [str(p.resolve()) for p in reversed(named)]


def _one_then_the_rest(sizes: list[int], slots: int) -> list[list[int]]:
    return [[0], list(range(1, len(sizes)))]


def _kill_when(
    client: Any, choose: Callable[[dict[str, Any]], str | None]
) -> tuple[dict[str, Any], Callable[[], None]]:
    """Watch the scheduler from a thread of this process and SIGKILL the first worker
    ``choose(client.processing())`` names; what it held, and the function that stops the
    watch (and raises what the watch raised)."""
    pids = client.run(os.getpid)
    killed: dict[str, Any] = {}
    errors: list[BaseException] = []
    stop = threading.Event()

    def watch() -> None:
        try:
            while not stop.is_set() and not killed:
                held = {w: keys for w, keys in client.processing().items() if keys}
                worker = choose(held)
                if worker is not None:
                    os.kill(pids[worker], signal.SIGKILL)
                    killed[worker] = held[worker]
                time.sleep(0.002)
        except BaseException as e:  # raised again in the test's thread
            errors.append(e)

    thread = threading.Thread(target=watch, daemon=True)
    thread.start()

    def done() -> None:
        stop.set()
        thread.join()
        if errors:
            raise errors[0]

    return killed, done


@pytest.mark.slow
@pytest.mark.parametrize("tasks", ["one per recording", "one, then the rest"])
def test_a_worker_killed_mid_campaign(
    recordings: list[Path], client: Any, tmp_path: Path, tasks: str, monkeypatch: Any
) -> None:
    """A worker is killed while it holds a task (of one recording, once a recording is
    committed; or of five, on a split that hands out one recording and then the rest, once
    the five's first is written and the rest are not): the campaign completes, nothing lost
    or twice. The kill waits on the campaign's own files, not on timing."""
    from thermrs.campaigns.sources import content_hash, recording_id

    out = tmp_path / "ds"
    by_size = sorted(recordings, key=lambda p: p.stat().st_size, reverse=True)
    second = str(by_size[1].resolve())  # the first of the five
    staged_second = f"{recording_id(second, content_hash(second))}.*"

    def choose(held: dict[str, Any]) -> str | None:
        if tasks == "one per recording":
            if not any((out / "_catalog").glob("*.parquet")):
                return None
            return next(iter(held), None)
        if not any((out / ".staging").glob(staged_second)):
            return None
        fives = (w for w, keys in held.items() if any(str(k).endswith(second) for k in keys))
        return next(fives, None)

    if tasks != "one per recording":
        monkeypatch.setattr("thermrs.campaigns.engine.split", _one_then_the_rest)
    client.wait_for_workers(2)  # one may have been restarted by the test before
    killed, stop_watching = _kill_when(client, choose)
    try:
        res = thermrs.campaign(recordings, out, client=client)
    finally:
        stop_watching()
    assert killed, "a worker was killed while it held a recording"
    assert sorted(res.extracted) == sorted(str(p.resolve()) for p in recordings)
    assert not res.failed and not res.unchanged
    check_against_single_files(res, recordings)
    # polars reads the dataset itself lazily, hive partitions and all.
    lazy = pl.scan_parquet(tmp_path / "ds" / "visits", hive_partitioning=True)
    assert lazy.select(pl.len()).collect().item() == sum(res.catalog["visits"])


@pytest.mark.slow
def test_the_cluster_thermrs_starts_splits_by_its_workers(
    recordings: list[Path], tmp_path: Path, monkeypatch: Any
) -> None:
    """Given no client, a campaign of several recordings starts a cluster of one worker per
    core (at most one per recording) and splits its recordings by that cluster's workers."""
    from thermrs.campaigns import engine

    seen: dict[str, Any] = {}
    real_split, real_cluster = engine.split, engine.local_cluster

    def spy_split(sizes: list[int], slots: int) -> list[list[int]]:
        seen["slots"] = slots
        return real_split(sizes, slots)

    def spy_cluster(workers: int, **kwargs: Any) -> Any:
        cluster = real_cluster(workers, **kwargs)
        # The workers the scheduler has (what `wait_for_workers` waited for); the cluster's
        # own `workers` dict is filled a moment later on its loop.
        seen["workers"] = len(cluster.scheduler_info["workers"])
        return cluster

    monkeypatch.setattr(engine, "split", spy_split)
    monkeypatch.setattr(engine, "local_cluster", spy_cluster)
    res = thermrs.campaign(recordings[:3], tmp_path / "ds")
    assert len(res.extracted) == 3
    assert seen["slots"] == seen["workers"] == min(3, os.cpu_count() or 1)


@pytest.mark.slow
def test_interrupted_campaign_resumes_and_unchanged_is_skipped(
    recordings: list[Path], client: Any, tmp_path: Path
) -> None:
    out = tmp_path / "ds"

    def stop_after_two(done: int, total: int, path: str) -> None:
        if done == 2:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        thermrs.campaign(recordings, out, client=client, progress=stop_after_two)
    first = thermrs.campaigns.Dataset(out).catalog()
    assert first.height == 2
    # What an interruption during a commit leaves: a staging folder, a partition with no
    # catalog row.
    (out / ".staging" / "x").mkdir(parents=True)
    ghost = out / "frames" / "recording=ghost-000000000000" / "run=run1"
    ghost.mkdir(parents=True)
    shutil.copy(next((out / "frames").rglob("*.parquet")), ghost / "part-0.parquet")

    res = thermrs.campaign(recordings, out, client=client)
    assert len(res.extracted) == 4 and len(res.unchanged) == 2
    assert not (out / ".staging" / "x").exists() and not ghost.exists()
    check_against_single_files(res, recordings)
    assert_frame_equal(
        res.catalog.filter(pl.col("recording").is_in(first["recording"].to_list())),
        first,
    )

    # Unchanged: nothing extracted; a file touched (same bytes) is hashed, not extracted.
    os.utime(recordings[0], ns=(1, 1))
    again = thermrs.campaign([str(recordings[0].parent)], out, client=client)
    assert again.extracted == [] and len(again.unchanged) == len(recordings)
    row = again.catalog.filter(pl.col("path") == str(recordings[0].resolve()))
    assert row["mtime_ns"].item() == 1
    assert (out / "catalog.parquet").exists()
    assert_frame_equal(pl.read_parquet(out / "catalog.parquet"), again.catalog)


def _start_cli(args: list[str]) -> subprocess.Popen[str]:
    """``thermrs ARGS…`` in a session of its own (its process group: a terminal's Ctrl-C
    signals the whole group), SIGINT as a terminal delivers it."""
    return interruptible(*args, new_session=True)


@pytest.mark.slow
@pytest.mark.parametrize("to", ["process", "group"])
def test_ctrl_c_stops_a_cli_campaign_at_once_and_it_resumes(
    recordings: list[Path], tmp_path: Path, to: str
) -> None:
    """SIGINT to ``thermrs extract`` (or, as a terminal's Ctrl-C, to its whole process group,
    its workers included) once the campaign has committed its first recording: exit 130
    within the functional bound below (measured: 0.1 s on 2 cores), one line saying how many
    recordings the dataset holds (as many as it does) and that the same command resumes, no
    Dask log line, no leaked semaphore; the same command then extracts the rest."""
    out = tmp_path / "ds"
    # One worker: the recordings run in turn, so that once one is committed the others are
    # still to come (seconds of extraction, against the milliseconds the signal takes).
    args = ["extract", str(recordings[0].parent), "--rig", str(thermrs.default_rig_path()),
            "-o", str(out), "--workers", "1"]  # fmt: skip
    proc = _start_cli(args)
    try:
        while proc.poll() is None and not any((out / "_catalog").glob("*.parquet")):
            time.sleep(0.01)
        assert proc.poll() is None, proc.communicate()
        if to == "group":
            os.killpg(proc.pid, signal.SIGINT)
        else:
            proc.send_signal(signal.SIGINT)
        # A functional bound (the issue: 3.5-6.9 s, a nanny waiting 4 s for each busy worker).
        _, err = proc.communicate(timeout=3)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.communicate()
    assert proc.returncode == 130, err
    lines = [ln for ln in err.splitlines() if not ln.startswith("thermrs: Dask dashboard: ")]
    n = len(list((out / "_catalog").glob("*.parquet")))
    assert 1 <= n < len(recordings)
    assert lines == [
        f"thermrs: interrupted: {n} of {len(recordings)} recordings extracted; "
        "run the same command again to resume"
    ], err
    assert "distributed." not in err and "leaked semaphore" not in err

    again = subprocess.run([sys.executable, "-m", "thermrs", *args], capture_output=True,
                           text=True, timeout=600)  # fmt: skip
    assert again.returncode == 0, again.stderr
    assert f"{len(recordings) - n} recordings extracted, {n} unchanged" in again.stderr
    cat = thermrs.campaigns.Dataset.open(out).catalog()
    assert sorted(cat["path"]) == sorted(str(p.resolve()) for p in recordings)


def test_one_recording_runs_in_process(one_recording: Path, tmp_path: Path) -> None:
    res = thermrs.campaign([one_recording], tmp_path / "ds")
    assert res.dashboard is None and len(res.extracted) == 1
    check_against_single_files(res, [one_recording])


@pytest.mark.slow
def test_runs_extracted_before_the_override_existed_read_it_as_null(
    recordings: list[Path], tmp_path: Path
) -> None:
    """A dataset whose first recording's runs table predates ``speed_pct`` (an older
    extraction) reads it as null there and keeps the newer recording's."""
    out = tmp_path / "ds"
    thermrs.campaign(recordings[:2], out)
    ds = thermrs.campaigns.Dataset.open(out)
    first = ds.catalog()["recording"][0]
    for f in (out / "runs").glob(f"recording={first}/**/*.parquet"):
        pl.read_parquet(f).drop("speed_pct", "speed_pct_source").write_parquet(f)
    runs = ds.scan("runs").collect().sort("recording", "run")
    old = runs.filter(pl.col("recording") == first)
    new = runs.filter(pl.col("recording") != first)
    assert old.height == new.height == 2
    assert old["speed_pct"].null_count() == 2
    assert new["speed_pct"].to_list() == [30.0, 75.0]  # SCENARIO's overrides


def test_speed_override_from_the_marker_or_the_joint_states(one_recording: Path) -> None:
    """The override each run was simulated at: stated by its marker; estimated from the joint
    states with the joints' rated maxima (here the simulator's own maxima, its default
    scenario's) where no marker states it; unknown without either."""
    from thermrs.campaigns.task import run_stats
    from thermrs.ingest import extract

    rig = thermrs.load_rig()
    ex = extract(one_recording, rig)
    tables = (ex.runs, ex.frames, ex.visits, ex.joints)
    truth = [30.0, 75.0]  # SCENARIO
    marked = run_stats(*tables, metadata=ex.report.metadata)
    assert marked["speed_pct"].to_list() == truth
    assert marked["speed_pct_source"].to_list() == ["marker", "marker"]
    rates = [152.0, 152.0, 152.0, 284.0, 293.0, 604.0]  # docs/scenarios.md, motion defaults
    est = run_stats(*tables, max_rate_deg_s=rates)
    assert est["speed_pct"].to_list() == pytest.approx(truth, abs=1.0)
    assert est["speed_pct_source"].to_list() == ["joint states"] * 2
    assert run_stats(*tables)["speed_pct"].null_count() == 2


@pytest.mark.slow
def test_a_script_without_a_main_guard_is_told_not_left_waiting(
    recordings: list[Path], tmp_path: Path
) -> None:
    """A script that starts a campaign cluster at its top level would be imported again by
    every worker process (each starting a cluster of its own) and wait for ever: it is
    refused at once, naming the line and the fix."""
    script = tmp_path / "go.py"
    script.write_text(
        "import sys\nimport thermrs\nthermrs.campaign(sys.argv[1:-1], sys.argv[-1], workers=2)\n"
    )
    p = subprocess.run(
        [sys.executable, str(script), *map(str, recordings[:2]), str(tmp_path / "ds")],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert p.returncode != 0
    assert "(line 3)" in p.stderr and 'if __name__ == "__main__":' in p.stderr, p.stderr
    guarded = tmp_path / "guarded.py"
    guarded.write_text(
        'import sys\nimport thermrs\n\nif __name__ == "__main__":\n'
        "    thermrs.campaign(sys.argv[1:-1], sys.argv[-1], workers=2)\n"
    )
    p = subprocess.run(
        [sys.executable, str(guarded), *map(str, recordings[:2]), str(tmp_path / "ds")],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert p.returncode == 0, p.stderr


def test_the_summary_shows_a_bounded_catalog_losses_first() -> None:
    from thermrs.cli.campaign import rows_to_show

    # 50 recordings: 3 lost data (one of them extracted now), 10 extracted now.
    cat = pl.DataFrame(
        {
            "recording": [f"r{i:02d}" for i in range(50)],
            "path": [f"/d/r{i:02d}.mcap" for i in range(50)],
            "losses": [1 if i in (7, 30, 44) else 0 for i in range(50)],
        }
    )
    now = {f"/d/r{i:02d}.mcap" for i in range(40, 50)}
    shown = rows_to_show(cat, now, limit=14)
    assert shown["recording"].to_list() == [
        "r44", "r07", "r30",  # lost data: extracted now first, then by recording
        *[f"r{i}" for i in range(40, 50) if i != 44],  # extracted now
        "r00", "r01",  # then the rest, by recording
    ]  # fmt: skip
    assert shown.columns == cat.columns
    small = cat.head(5)
    assert rows_to_show(small, now, limit=14).equals(small)


def _worker_log_level() -> int:
    import logging

    return logging.getLogger("distributed.worker").getEffectiveLevel()


@pytest.mark.slow
def test_workers_are_quiet_when_thermrs_closes_its_cluster() -> None:
    # A worker's last heartbeat can race the scheduler's closing and log a traceback after a
    # campaign that succeeded (dask/distributed#7105): errors show while the cluster works and
    # not once thermrs closes it.
    from distributed import Client
    from thermrs.campaigns.engine import local_cluster, quiet_workers

    with local_cluster(1) as cluster, Client(cluster) as c:
        before = c.run(_worker_log_level)
        quiet_workers(c)
        after = c.run(_worker_log_level)
    assert list(before.values()) and all(v <= 40 for v in before.values())  # ERROR = 40
    assert list(after.values()) and all(v > 40 for v in after.values())


def test_catalog_reads_old_fragments_and_names_a_damaged_one(
    one_recording: Path, tmp_path: Path
) -> None:
    out = tmp_path / "ds"
    thermrs.campaign([one_recording], out)
    (frag,) = (out / "_catalog").glob("*.parquet")
    row = pl.read_parquet(frag)
    # A fragment written before the catalog had a `report` column, with a narrower integer
    # and a column this version does not know: read with nulls, upcast, the extra left out.
    old = row.drop("report").with_columns(
        pl.lit("older-copy").alias("recording"),
        pl.col("losses").cast(pl.Int32),
        pl.lit(1.0).alias("some_future_column"),
    )
    old.write_parquet(out / "_catalog" / "older-copy.parquet")
    cat = thermrs.campaigns.Dataset.open(out).catalog()
    assert cat["recording"].to_list() == ["older-copy", row["recording"].item()]
    assert cat.schema == pl.Schema(thermrs.campaigns.dataset.CATALOG_SCHEMA)
    assert cat["report"].to_list() == [None, row["report"].item()]
    assert cat["losses"].to_list() == [row["losses"].item()] * 2
    assert_frame_equal(cat.filter(pl.col("recording") != "older-copy"), row)

    (out / "_catalog" / "cut.parquet").write_bytes(frag.read_bytes()[:100])
    with pytest.raises(thermrs.InputError, match=r"_catalog/cut\.parquet is unreadable"):
        thermrs.campaigns.Dataset.open(out).catalog()


@pytest.mark.slow
def test_workers_without_the_dataset_folder_send_their_tables(
    recordings: list[Path], client: Any, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Workers that do not see the dataset's staging folder (a cluster without shared storage:
    here the token they look for is not where they look) send the tables back as Arrow, and the
    client writes them: the dataset is the same as each recording's own extraction."""
    from thermrs.campaigns import staging

    seen: list[str] = []
    real_commit = thermrs.campaigns.dataset.Dataset.commit

    def commit(self: Any, row: Any, tables: Any = None, *, staged: Any = None) -> None:
        seen.append("tables" if tables is not None else "staged")
        real_commit(self, row, tables, staged=staged)

    monkeypatch.setattr(thermrs.campaigns.dataset.Dataset, "commit", commit)
    monkeypatch.setattr(staging, "new_token", lambda root: "campaign-nowhere")
    root = tmp_path / "ds"
    root.mkdir()
    res = thermrs.campaign(recordings[:3], root, client=client)
    assert seen == ["tables"] * 3
    check_against_single_files(res, recordings[:3])
    assert not (root / ".staging").exists()
    # With the token where workers look, they write the partitions themselves.
    monkeypatch.undo()
    monkeypatch.setattr(thermrs.campaigns.dataset.Dataset, "commit", commit)
    seen.clear()
    res = thermrs.campaign(recordings[:3], tmp_path / "ds2", client=client)
    assert seen == ["staged"] * 3
    check_against_single_files(res, recordings[:3])
    assert not (tmp_path / "ds2" / ".staging").exists()


@pytest.mark.slow
def test_cli_campaign_on_a_scheduler(recordings: list[Path], client: Any, tmp_path: Path) -> None:
    out = tmp_path / "ds"
    pattern = str(recordings[0].parent / "r[12].mcap")
    args = [sys.executable, "-m", "thermrs", "extract", pattern, str(recordings[2])]
    args += ["--rig", str(thermrs.default_rig_path()), "-o", str(out)]
    args += ["--scheduler", client.scheduler.address]
    p = subprocess.run(args, capture_output=True, text=True, timeout=120)
    assert p.returncode == 0, p.stderr
    assert "3 recordings extracted" in p.stderr
    cat = pl.read_parquet(out / "catalog.parquet")
    assert sorted(Path(x).name for x in cat["path"]) == ["r1.mcap", "r2.mcap", "r3.mcap"]
    # The campaign page: α and drift per run, and the held-out folds.
    page = tmp_path / "page.md"
    rig = str(thermrs.default_rig_path())
    cmd = [sys.executable, "-m", "thermrs", "campaign", str(out), "--rig", rig]
    p = subprocess.run(
        [*cmd, "--rule", "leave-one-run-out", "-o", str(page)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert p.returncode == 0, p.stderr
    text = page.read_text()
    assert text.count("#run1 |") + text.count("| run1 |") >= 3 and "## Held out" in text
    assert text.count("| without ") == 6
    p = subprocess.run([*cmd, "--where", "colour=red"], capture_output=True, text=True)
    assert p.returncode == 2 and "unknown key 'colour'" in p.stderr and "Traceback" not in p.stderr
    # A pattern that matches nothing is bad input, exit 2 with one line.
    args[4] = str(recordings[0].parent / "nothing*.mcap")
    p = subprocess.run(args, capture_output=True, text=True, timeout=120)
    assert p.returncode == 2 and "matches no file" in p.stderr
    assert "Traceback" not in p.stderr


@pytest.mark.slow
def test_runs_by_query_alpha_per_run_and_rules(
    recordings: list[Path], client: Any, tmp_path: Path
) -> None:
    from datetime import date

    from thermrs.campaigns.select import campaign_runs, folds, parse_query, run_tables
    from thermrs.campaigns.summary import alpha_by_run, holdout_by_rule
    from thermrs.errors import InputError
    from thermrs.fit import fit_alpha
    from thermrs.runs import load_runs

    rig = thermrs.load_rig()
    res = thermrs.campaign(recordings[:3], tmp_path / "ds", client=client)
    ds = res.dataset
    every = campaign_runs(ds)
    assert every.height == 6
    # The simulator moved 2.5 times faster in run2 (75 % against 30 % speed).
    fast = campaign_runs(ds, "speed > 150")
    assert set(fast["run"]) == {"run2"} and fast.height == 3
    ratio = fast["speed_deg_s"].mean() / campaign_runs(ds, "run=run1")["speed_deg_s"].mean()
    assert ratio == pytest.approx(75 / 30, rel=0.02)
    assert campaign_runs(ds, f"robot={rig.model}, date=2025-06-15").height == 6
    with pytest.raises(InputError, match="no run matches"):
        campaign_runs(ds, "date>=2030-01-01")
    with pytest.raises(InputError, match="unknown key 'colour'"):
        parse_query("colour=red")
    with pytest.raises(InputError, match="is not a float"):
        parse_query("speed>fast")

    # α per run from the dataset is α fitted on that run of the file itself.
    per_run = alpha_by_run(ds, rig)
    for row in per_run.iter_rows(named=True):
        path = res.catalog.filter(pl.col("recording") == row["recording"])["path"].item()
        own = fit_alpha(load_runs(f"{path}#{row['run']}", rig).tables, rig)
        assert row["alpha_per_k"] == pytest.approx(own.alpha_per_k, rel=1e-9)
    # ... and close to the simulated truth (the rig's α) on the whole.
    assert per_run["alpha_per_k"].median() == pytest.approx(rig.alpha_per_k, rel=0.15)
    assert (per_run["drift_um"] > 1).all()

    tables = run_tables(ds, every, rig)
    assert [t["run"][0] for t in tables] == [
        f"{a}#{b}" for a, b in every.select("recording", "run").rows()
    ]
    loro = holdout_by_rule(ds, rig, rule="leave-one-run-out")
    assert loro.height == 6 and (loro["train_runs"] == 5).all()
    assert (loro["holdout_rms_um"] < 10).all()

    # Train on one day, hold out the next (dates made up: the simulator starts every file on
    # the same day).
    days = every.with_columns(
        date=pl.Series([date(2026, 1, 1 + i // 2) for i in range(every.height)])
    )
    f = folds(days, "by-day")
    assert [(len(x.train), len(x.holdout)) for x in f] == [(2, 2), (2, 2)]
    assert f[0].holdout == f[1].train
    with pytest.raises(InputError, match="at least two days"):
        folds(every, "by-day")
