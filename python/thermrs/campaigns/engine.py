"""Running a campaign: which recordings need work, where it runs (Dask distributed), and the
commits as results come back.

The engine is Dask distributed, never a home-made pool: :func:`campaign` maps
:func:`thermrs.campaigns.task.run_job` over the recordings (in tasks of consecutive recordings,
:mod:`thermrs.campaigns.split`) on a ``distributed.Client``: the
one given, one connected to ``scheduler``, or a ``LocalCluster`` of worker processes when
neither is given and more than one recording needs work (a single recording runs in process).
Results come back as Arrow tables and are committed by this process as they arrive, one
recording at a time (:class:`~thermrs.campaigns.dataset.Dataset`), so that a campaign stopped
anywhere resumes where it stopped, and a worker that dies only has its task (a run of
recordings, :mod:`thermrs.campaigns.split`) run again elsewhere (jobs have no side effects:
nothing is lost or written twice).

Stopping: a cluster thermrs starts is shut down at once when the campaign ends or Ctrl-C
stops it (:func:`close_now`: its workers killed, not waited for), and its worker processes
never take a Ctrl-C themselves (:func:`local_cluster`); Ctrl-C raises
:class:`CampaignInterrupted`, which says how many recordings the dataset holds.

Skipping work: a recording whose path, size and modification time match a catalog row made
with the same rig and thermrs version is not read at all; one whose bytes hash to such a row
(a file touched or copied) is hashed but not extracted.
"""

from __future__ import annotations

import json
import logging
import os
import signal
import time
from collections.abc import Callable, Generator, Iterator, Sequence
from contextlib import contextmanager, suppress
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import polars as pl

from thermrs.atomic import hold_interrupts, release_interrupts
from thermrs.campaigns.dataset import Dataset
from thermrs.campaigns.sources import Source, expand
from thermrs.campaigns.split import split
from thermrs.campaigns.task import Job, run_job, run_jobs
from thermrs.errors import InputError
from thermrs.rig import Rig, as_rig, load_rig

__all__ = [
    "KILL_AFTER_S",
    "QUIET_CLUSTER",
    "WORKER_ENV",
    "CampaignInterrupted",
    "CampaignResult",
    "Progress",
    "campaign",
    "close_now",
    "local_cluster",
    "quiet_workers",
    "rig_identity",
]

#: ``progress(done, total, recording_path)`` after each recording (skipped ones included).
Progress = Callable[[int, int, str], object]


@dataclass
class CampaignResult:
    """What a campaign did.

    Attributes
    ----------
    dataset
        The dataset written (its :meth:`~Dataset.catalog` and :meth:`~Dataset.scan`).
    extracted, unchanged
        Recordings extracted now, and recordings already in the dataset (by path and stat, or
        by content hash) and not extracted again.
    failed
        ``(path, one-line reason)`` of recordings that could not be read (bad input).
    dashboard
        The Dask dashboard's address, where a cluster ran the work.
    seconds
        Wall time of the campaign.
    """

    dataset: Dataset
    extracted: list[str] = field(default_factory=list)
    unchanged: list[str] = field(default_factory=list)
    failed: list[tuple[str, str]] = field(default_factory=list)
    dashboard: str | None = None
    seconds: float = 0.0

    @property
    def catalog(self) -> pl.DataFrame:
        """The dataset's catalog (one row per recording)."""
        return self.dataset.catalog()

    @property
    def data_loss(self) -> bool:
        """Whether any recording of the campaign lost data (exit 3 for the CLI)."""
        cat = self.catalog
        return bool(cat.height and cat["losses"].sum())


class CampaignInterrupted(KeyboardInterrupt):
    """Ctrl-C during a campaign, with how far it got: a ``KeyboardInterrupt`` (whoever stops
    on Ctrl-C stops on it), raised once the cluster thermrs started is shut down.

    Every recording counted in ``done`` is committed to the dataset; the same campaign run
    again extracts only the others.

    Attributes
    ----------
    done
        Recordings of the campaign in the dataset: extracted now, or already there.
    total
        Recordings the campaign names.
    extracted
        Of ``done``, those this campaign extracted before the interruption.
    """

    def __init__(self, done: int, total: int, extracted: int) -> None:
        super().__init__(done, total, extracted)
        self.done = done
        self.total = total
        self.extracted = extracted

    def __str__(self) -> str:
        return f"{self.done} of {self.total} recordings extracted"


def rig_identity(rig: Rig | str | os.PathLike[str] | None) -> tuple[Rig, str, str]:
    """The rig, its file's text (what workers load) and its hash (BLAKE3 of the validated
    rig as JSON, so that two files of the same rig hash alike; its ``[tolerances]``, which
    only the diagnoser's null uses, left out)."""
    from blake3 import blake3

    import thermrs._native as _native

    r = load_rig() if rig is None else as_rig(rig)
    path = Path(r.source)
    text = path.read_text(encoding="utf-8") if path.is_file() else None
    if text is None:
        raise InputError(f"rig {r.source}: a campaign needs a rig read from a file")
    as_data = json.loads(_native.Rig.from_toml(text, r.source).to_json())
    as_data.pop("tolerances", None)
    digest = blake3(json.dumps(as_data, separators=(",", ":")).encode()).hexdigest()
    return r, text, digest


def _version() -> str:
    from importlib.metadata import version

    return version("thermrs")


def campaign(
    recordings: Sequence[str | os.PathLike[str]],
    out: str | os.PathLike[str],
    *,
    rig: Rig | str | os.PathLike[str] | None = None,
    client: Any = None,
    scheduler: str | None = None,
    workers: int | None = None,
    visit_tolerance_deg: float | None = None,
    progress: Progress | None = None,
    on_cluster: Callable[[str | None], object] | None = None,
) -> CampaignResult:
    """Extract many recordings into one Parquet dataset partitioned by recording and run.

    Parameters
    ----------
    recordings
        Files, glob patterns and folders (every ``*.mcap`` below them).
    out
        The dataset folder (created; its parent must exist). A dataset already there is
        added to: recordings it holds with the same content, rig and thermrs version are not
        extracted again, and what an interrupted campaign left half-written is removed.
    rig
        The rig (a :class:`~thermrs.Rig` read from a file, or a rig file; default the
        embedded paper rig).
    client
        A ``distributed.Client`` to run on (the caller keeps it).
    scheduler
        Else the address of a Dask scheduler to connect to (``tcp://host:8786``).
    workers
        Else the number of worker processes of the ``LocalCluster`` started when more than
        one recording needs work (default: the cores, at most one per recording).
    visit_tolerance_deg
        The joint tolerance of a visit (see :func:`thermrs.extract`); part of what makes a
        recording's extraction current.
    progress
        Called as ``progress(done, total, path)`` as recordings finish.
    on_cluster
        Called once with the Dask dashboard's address (``None`` where no cluster runs).

    Returns
    -------
    CampaignResult
        The dataset, what was extracted, skipped and failed, the dashboard address.

    Notes
    -----
    Recordings are handed to the workers largest first, whatever order they are named in, so
    that a long recording does not run alone at the end of the campaign.

    Raises
    ------
    InputError
        A recording name that matches nothing; the dataset folder cannot be made.
    CampaignInterrupted
        Ctrl-C (a ``KeyboardInterrupt``): the cluster thermrs started is shut down at once
        (its running extractions killed); how many recordings are in the dataset.

    Examples
    --------
    >>> import thermrs
    >>> res = thermrs.campaign(["day1/*.mcap", "day2/"], "campaign")  # doctest: +SKIP
    >>> res.extracted, res.unchanged, res.dashboard  # doctest: +SKIP
    >>> res.dataset.scan("visits").filter(run="run2").collect()  # doctest: +SKIP
    """
    from thermrs.visits import DEFAULT_TOLERANCE_DEG

    t0 = time.perf_counter()
    sources = expand([str(r) for r in recordings])
    identity = rig_identity(rig)
    version = _version()
    ds = Dataset(Path(out), create=True)
    ds.clean()
    options = json.dumps(
        {"visit_tolerance_deg": visit_tolerance_deg or DEFAULT_TOLERANCE_DEG}, sort_keys=True
    )
    result = CampaignResult(dataset=ds)
    todo, jobs, by_hash = _plan(ds, sources, identity, version, options, result)
    done, total = len(result.unchanged), len(sources)
    if progress is not None:
        progress(done, total, "")
    sizes = [s.size_bytes for s in todo]
    try:
        with _engine(jobs, sizes, client, scheduler, workers) as (results, dashboard):
            if on_cluster is not None:
                on_cluster(dashboard)
            _commit_each(ds, results, todo, by_hash, result, progress, total)
            result.dashboard = dashboard
        ds.close_staging()
        ds.consolidate()
    except KeyboardInterrupt:
        # The cluster is shut down by now; what was committed stays (the next campaign
        # removes the staged rest and writes catalog.parquet).
        n = len(result.extracted) + len(result.unchanged)
        raise CampaignInterrupted(n, total, len(result.extracted)) from None
    result.seconds = time.perf_counter() - t0
    return result


def _plan(
    ds: Dataset,
    sources: Sequence[Source],
    identity: tuple[Rig, str, str],
    version: str,
    options: str,
    result: CampaignResult,
) -> tuple[list[Source], list[Job], dict[str, str]]:
    """The recordings to extract (:func:`_to_extract`), a job for each (the dataset's staging
    folder opened for them), and the recordings the dataset holds by content hash, extracted
    with this rig (``identity``: :func:`rig_identity`), thermrs ``version`` and ``options``."""
    r, text, rig_hash = identity
    same = ds.catalog().filter(
        (pl.col("rig_hash") == rig_hash)
        & (pl.col("thermrs_version") == version)
        & (pl.col("options") == options)
    )
    by_hash = dict(zip(same["content_hash"], same["recording"], strict=True))
    todo = _to_extract(sources, same, result)
    stage, token = ds.open_staging()
    jobs = [
        Job(
            str(s.path),
            text,
            r.source,
            rig_hash,
            version,
            options,
            frozenset(by_hash),
            known_sizes=frozenset(int(n) for n in same["size_bytes"].drop_nulls()),
            stage=str(stage),
            token=token,
        )
        for s in todo
    ]
    return todo, jobs, by_hash


def _to_extract(
    sources: Sequence[Source], same: pl.DataFrame, result: CampaignResult
) -> list[Source]:
    """The recordings to extract, largest first; those the catalog rows ``same`` hold by path,
    size and modification time are added to ``result.unchanged`` instead.

    Largest first: a long recording started last would run alone at the end while the other
    workers idle; in this order the campaign is at most 4/3 of the best split of its work over
    the workers (Graham's bound for longest-processing-time-first), where the listing's order
    can leave a whole recording's time as the tail."""
    by_stat = {
        (row["path"], row["size_bytes"], row["mtime_ns"]) for row in same.iter_rows(named=True)
    }
    todo: list[Source] = []
    for s in sources:
        if (str(s.path), s.size_bytes, s.mtime_ns) in by_stat:
            result.unchanged.append(str(s.path))
        else:
            todo.append(s)
    return sorted(todo, key=lambda s: s.size_bytes, reverse=True)


def _commit_each(
    ds: Dataset,
    results: Iterator[dict[str, Any]],
    todo: Sequence[Source],
    by_hash: dict[str, str],
    result: CampaignResult,
    progress: Progress | None,
    total: int,
) -> None:
    """Every job's result committed as it comes (:func:`_absorb`), ``progress`` told."""
    stat = {str(s.path): s for s in todo}
    done = len(result.unchanged)
    for res in results:
        # A commit is whole and counted, or not made: Ctrl-C waits for it (renames and one
        # catalog fragment), so that the count it reports is the dataset's.
        held = hold_interrupts()
        try:
            _absorb(ds, res, stat, by_hash, result)
        finally:
            release_interrupts(held)
        done += 1
        if progress is not None:
            progress(done, total, res["path"])


def _absorb(
    ds: Dataset,
    res: dict[str, Any],
    stat: dict[str, Source],
    by_hash: dict[str, str],
    result: CampaignResult,
) -> None:
    """Commit one job's result."""
    path = res["path"]
    s = stat[path]
    if res["status"] == "failed":
        result.failed.append((path, res["error"]))
    elif res["status"] == "unchanged":
        ds.touch(by_hash[res["content_hash"]], {"path": path, "mtime_ns": s.mtime_ns})
        result.unchanged.append(path)
    else:
        row = dict(res["row"], mtime_ns=s.mtime_ns, size_bytes=s.size_bytes)
        ds.commit(row, res.get("tables"), staged=res.get("staged"))
        result.extracted.append(path)


@contextmanager
def _engine(
    jobs: list[Job], sizes: list[int], client: Any, scheduler: str | None, workers: int | None
) -> Iterator[tuple[Iterator[dict[str, Any]], str | None]]:
    """Results of ``jobs`` (recordings of ``sizes`` bytes) as they complete, and the dashboard
    address where a cluster runs them.

    A cluster it started is shut down at once when the campaign ends or is stopped (Ctrl-C):
    its workers are killed, not waited for (:func:`close_now`). On a cluster it was given,
    the tasks still running are cancelled and the cluster is left running.
    """
    if not jobs:
        yield iter(()), None
        return
    if client is None and scheduler is None and len(jobs) == 1:
        yield (run_job(j) for j in jobs), None
        return
    from distributed import Client

    cluster = None
    own = client is None
    slots = 0  # worker threads that run tasks at once
    if own:
        if scheduler is not None:
            client = Client(scheduler)  # type: ignore[no-untyped-call]
        else:
            slots = workers or max(1, min(len(jobs), os.cpu_count() or 1))
            cluster = local_cluster(slots)  # one thread per worker
            try:
                client = Client(cluster)  # type: ignore[no-untyped-call]
            except BaseException:
                close_now(cluster)
                raise
    # None known yet (workers still to join a scheduler): one task per recording.
    slots = slots or sum(client.nthreads().values())
    tasks = [[jobs[i] for i in g] for g in split(sizes, slots)] if slots else [[j] for j in jobs]
    # Tasks on a cluster of our own are not cancelled when stopped: its workers are killed,
    # which a cancellation would only make them log about first.
    results = _as_completed(client, tasks, cancel=cluster is None)
    try:
        yield results, client.dashboard_link
    finally:
        results.close()  # cancels what is still running (not on a cluster of our own)
        if cluster is not None:
            # Done or stopped, the same: every result is committed or will not be.
            close_now(cluster, client)
        elif own:
            client.close()


#: The environment of a worker of :func:`local_cluster`: every library's thread pool at one
#: thread, since each worker is one process on one core (the Rust core's rayon pool, polars'
#: own pool, BLAS/OpenMP). A worker left with a pool per core runs as many threads as the
#: machine has cores beside the other workers'; measured on 2 cores, polars' second thread
#: made a 1-worker campaign slower and cost it 7 % more CPU (benchmarks/bench_campaign_tasks.py).
WORKER_ENV = {"RAYON_NUM_THREADS": "1", "POLARS_MAX_THREADS": "1", "OMP_NUM_THREADS": "1"}

#: The Dask settings of a :func:`local_cluster`: its processes' background work turned down,
#: since on one machine it takes the cores the workers extract on. Each server's event-loop
#: tick (which only detects a blocked loop) at 1 s instead of 20 ms, the workers' statistical
#: profiler (the dashboard's "Profile" page, sampling the running task 100 times a second)
#: off, and the system monitor (the dashboard's CPU and memory plots) at 2 s instead of
#: 0.5 s. The memory monitor, which keeps a worker within its memory limit, is left as it is.
#: Measured on 2 cores (``benchmarks/bench_campaign_tasks.py``):
#: a campaign of 24 short recordings ran 6 % faster, its client process using
#: 0.167 s of CPU instead of 0.208 s.
#:
#: And glibc's allocator left as it is in any process: Dask's nannies set
#: ``MALLOC_TRIM_THRESHOLD_=65536`` in their workers, which fixes glibc's threshold for
#: mapping a large allocation of its own (it adapts otherwise), so that every large array is
#: mapped and unmapped afresh, its pages faulted in each time. Measured on 2 cores
#: (``benchmarks/bench_folds.py``, and one diagnosis fold of three 15-h runs in a plain
#: process with the variable set): the fold took 8.9 s instead of 6.8 s, 10 s of the run's
#: CPU in the kernel instead of 0.9 s; on a worker with it, 11.4 s, without it 6.6 s.
QUIET_CLUSTER = {
    "distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None,
    "distributed.admin.tick.interval": "1s",
    "distributed.worker.profile.enabled": False,
    "distributed.admin.system-monitor.interval": "2s",
}


#: Seconds a nanny of a cluster thermrs started is given to close when :func:`close_now` shuts
#: the cluster down (its worker process is killed first: a worker inside an extraction would
#: not stop before the extraction's end).
KILL_AFTER_S = 0.25


def local_cluster(workers: int, **kwargs: Any) -> Any:
    """The ``distributed.LocalCluster`` a campaign starts when given no client or scheduler:
    ``workers`` worker processes of one thread each (:data:`WORKER_ENV`), background work
    turned down (:data:`QUIET_CLUSTER`), dashboard on a free port; returned once every
    worker has joined.

    Ctrl-C is this process's alone: the cluster's event loop, and the worker processes it
    starts, have SIGINT blocked (on POSIX), so that a Ctrl-C in a terminal, which signals
    every process of the foreground job, stops the campaign without each worker printing
    its own traceback. Interrupted while the workers start, the cluster is shut down
    (:func:`close_now`) before the ``KeyboardInterrupt`` goes on.

    Parameters
    ----------
    workers
        Worker processes (one per core is what the machine can run at once).
    **kwargs
        Passed on to ``LocalCluster`` (e.g. ``silence_logs``).

    Examples
    --------
    >>> from distributed import Client
    >>> from thermrs.campaigns.engine import local_cluster
    >>> with local_cluster(2) as cluster, Client(cluster) as client:  # doctest: +SKIP
    ...     thermrs.campaign(["day1/"], "campaign", client=client)

    Raises
    ------
    RuntimeError
        Called while a worker process imports the script that started it (a script that runs a
        campaign without ``if __name__ == "__main__":``): each worker would start a cluster of
        its own and the campaign would wait for them forever.
    """
    import multiprocessing

    line = _unguarded_script_line()
    if line is not None or getattr(multiprocessing.current_process(), "_inheriting", False):
        where = f" (line {line})" if line is not None else ""
        raise RuntimeError(
            f"a campaign cluster started from a script's top level{where}: its worker "
            "processes import the script again and would start clusters of their own; put "
            'the campaign under `if __name__ == "__main__":`'
        )
    import dask
    from distributed import LocalCluster

    # Read when the scheduler and nannies are made; each nanny hands it to its worker.
    with dask.config.set(QUIET_CLUSTER):
        runner = _loop_without_sigint()
        try:
            cluster = LocalCluster(  # type: ignore[no-untyped-call]
                n_workers=0,
                threads_per_worker=1,
                processes=True,
                dashboard_address=":0",
                env=dict(WORKER_ENV),
                loop=None if runner is None else runner.loop,
                **kwargs,
            )
        finally:
            # Loop runners count the users of a loop and the last one stops it: from here the
            # cluster's own runner is its only user (closing the cluster stops the loop).
            if runner is not None:
                runner.stop()
        try:
            cluster.scale(workers)  # type: ignore[no-untyped-call]
            cluster.wait_for_workers(workers)
        except BaseException:
            close_now(cluster)
            raise
    return cluster


def _unguarded_script_line() -> int | None:
    """The line of the running script (``__main__``, a file) from which this call came when
    that line is at the script's top level outside ``if __name__ == "__main__":``; else
    ``None``. Worker processes start by importing the script: such a call would run again in
    each of them."""
    import ast
    import sys

    frame = sys._getframe(1)
    while frame is not None and not (
        frame.f_globals.get("__name__") == "__main__" and frame.f_code.co_name == "<module>"
    ):
        frame = frame.f_back  # type: ignore[assignment]
    main = sys.modules.get("__main__")
    spec = getattr(main, "__spec__", None)
    if spec is not None and (spec.name == "__main__" or spec.name.endswith(".__main__")):
        return None  # a package's __main__ (``python -m pkg``): workers do not import it again
    path = getattr(main, "__file__", None)
    if frame is None or not path or frame.f_code.co_filename != path:
        return None
    try:
        tree = ast.parse(Path(path).read_text())
    except (OSError, SyntaxError, ValueError):
        return None
    line = frame.f_lineno
    for node in tree.body:
        if not isinstance(node, ast.If) or not (node.lineno <= line <= (node.end_lineno or 0)):
            continue
        t = node.test
        if (
            isinstance(t, ast.Compare)
            and isinstance(t.left, ast.Name)
            and t.left.id == "__name__"
            and any(isinstance(c, ast.Constant) and c.value == "__main__" for c in t.comparators)
        ):
            return None
    return line


def _loop_without_sigint() -> Any:
    """A started ``distributed.utils.LoopRunner``: a Tornado IO loop on a thread of its own
    that has SIGINT blocked, for a ``LocalCluster`` (``None`` where signal masks do not
    exist: the cluster makes its own loop).

    Threads and processes inherit the signal mask of the thread that starts them: the worker
    processes a cluster starts from its loop's threads never take a Ctrl-C meant for the
    campaign."""
    if not hasattr(signal, "pthread_sigmask"):
        return None
    from multiprocessing import resource_tracker

    from distributed.utils import LoopRunner

    # Started here if it has not been: starting it later, on the loop's thread, would unblock
    # SIGINT there (the tracker's start blocks SIGINT and SIGTERM and then unblocks them).
    resource_tracker.ensure_running()
    runner = LoopRunner()
    old = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        runner.start()  # type: ignore[no-untyped-call]
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)
    return runner


@contextmanager
def _dask_silenced() -> Iterator[None]:
    """Dask's loggers in this process (and Tornado's, whose loop runs the cluster) silenced:
    a cluster shut down in a hurry logs warnings about workers it killed."""
    names = [
        n
        for n in list(logging.root.manager.loggerDict)
        if n.split(".")[0] in ("distributed", "tornado")
    ]
    loggers = [logging.getLogger(n) for n in ["distributed", "tornado", *names]]
    before = [lg.disabled for lg in loggers]
    for lg in loggers:
        lg.disabled = True
    try:
        yield
    finally:
        for lg, d in zip(loggers, before, strict=True):
            lg.disabled = d


def close_now(cluster: Any, client: Any = None) -> None:
    """Shut a ``LocalCluster`` down at once, without waiting for the tasks it runs: its
    worker processes killed and their nannies closed (at most :data:`KILL_AFTER_S` each),
    then ``client`` (if given) and the cluster closed. What is shut down this way logs
    nothing (Dask's loggers are silenced meanwhile; a killed worker cannot log). A Ctrl-C
    meanwhile is raised once it is done.

    Parameters
    ----------
    cluster
        The cluster (one that :func:`local_cluster` made: its nannies in this process).
    client
        A client of that cluster, closed with it.
    """

    import asyncio

    async def kill() -> None:
        nannies = list(getattr(cluster, "workers", {}).values())
        # Killed before their nannies close them: asked to stop, a worker would log the
        # tasks it cancels. The nannies' closing starts before the loop hears of the deaths,
        # so that none restarts its worker. Workers still starting (their nannies are not
        # among the cluster's workers yet, only among those it made) are killed too: a
        # nanny waits for its worker to have started before it closes it.
        for n in {*nannies, *getattr(cluster, "_created", ())}:
            pid = getattr(getattr(n, "process", None), "pid", None)
            if pid:
                with suppress(OSError):
                    os.kill(pid, getattr(signal, "SIGKILL", signal.SIGTERM))
        await asyncio.gather(
            *(n.close(timeout=KILL_AFTER_S, reason="thermrs-close-now") for n in nannies),
            return_exceptions=True,
        )

    # A Ctrl-C meanwhile waits (it would cancel the closing half-way, leaving the cluster
    # closing for ever), and is raised once the cluster is closed.
    held = hold_interrupts()
    try:
        with _dask_silenced():
            with suppress(Exception):
                cluster.sync(kill, callback_timeout=5)
            if client is not None:
                with suppress(Exception):
                    client.close(timeout=2)
            with suppress(Exception):
                cluster.close(timeout=5)
    finally:
        release_interrupts(held)


def _quiet_worker_log() -> None:
    logging.getLogger("distributed.worker").setLevel(logging.CRITICAL)


def quiet_workers(client: Any) -> None:
    """Before closing a cluster gracefully (one of the caller's own, after a campaign):
    silence its workers' log, whose last heartbeat can race the scheduler's closing and print
    a traceback after a campaign that succeeded (``Failed to communicate with scheduler
    during heartbeat``; dask/distributed issue 7105, seen about once in twenty closings).
    A cluster thermrs started needs none of it: :func:`close_now` kills its workers, which
    then log nothing."""
    with suppress(Exception):
        client.run(_quiet_worker_log)


def _as_completed(
    client: Any, tasks: list[list[Job]], *, cancel: bool = True
) -> Generator[dict[str, Any], None, None]:
    """Map the tasks (each a run of recordings) on the cluster and yield each recording's
    result as its task's arrive (the future released right after, so that the cluster holds
    no finished result); stopped, the tasks are cancelled if ``cancel``."""
    from distributed import as_completed

    # Keys name the campaign (its staging token) as well as the task's first file: a task of
    # an interrupted campaign that a worker is still running must not be taken for this
    # campaign's (its result names a staging folder this campaign has cleaned away).
    futures = client.map(
        run_jobs,
        tasks,
        key=[f"thermrs-extract-{t[0].token}-{t[0].path}" for t in tasks],
        pure=False,
    )
    try:
        for fut in as_completed(futures):  # type: ignore[no-untyped-call]
            res = fut.result()
            fut.release()
            yield from res
    except BaseException:
        if cancel:
            client.cancel(futures)
        raise
