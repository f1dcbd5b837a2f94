"""The one fold runner: an analysis run on every split, side by side on Dask workers when
there are several (``diagnose`` and ``design`` on files or with ``--rule``, or any list of
splits: anything with a ``name``, such as :class:`thermrs.analyses.inputs.Split`).

:func:`run_folds` runs one analysis of the library (``analysis(train, holdout, rig, …)``) per
split and wraps each result with its split; :func:`map_folds` runs any picklable task.

Each fold is a task of its own: its run tables and the rig go to a worker, its result (a
diagnosis, a design) comes back. The cluster is the campaign's (:func:`~thermrs.campaigns.
engine.local_cluster`: one process per core, each with its libraries' thread pools at one
thread; shut down at once when the work ends or Ctrl-C stops it), a ``distributed.Client``
the caller gives, or a scheduler's address. One fold, or one core, runs in this process: a
cluster's start (worker processes importing thermrs) would cost more than it saves.

Progress: what a fold says on its worker comes back as it is said (a Dask event topic), the
fold's name before it, and the end of each fold as it ends.

Results are the same as in this process, whichever worker ran a fold: every fold's random
draws come from its own seed, not from a shared stream.
"""

from __future__ import annotations

import os
import time
import uuid
from collections.abc import Callable, Sequence
from contextlib import suppress
from functools import partial
from typing import Any, Protocol, TypeVar

__all__ = ["Fold", "FoldTask", "Progress", "map_folds", "prefixed", "run_folds"]


class Fold(Protocol):
    """What a fold must have: its name (empty for the one split of files)."""

    @property
    def name(self) -> str: ...


S = TypeVar("S", bound=Fold)
R = TypeVar("R")

#: Called with a short message as the work goes on.
Progress = Callable[[str], object]

#: One fold's analysis: ``task(split, progress)``, a picklable callable (a module-level
#: function, or a ``functools.partial`` of one) for it to run on a worker.
FoldTask = Callable[[S, "Progress | None"], R]


def map_folds(
    task: FoldTask[S, R],
    sets: Sequence[S],
    *,
    client: Any = None,
    scheduler: str | None = None,
    workers: int | None = None,
    progress: Progress | None = None,
) -> list[R]:
    """``task`` run on every split, side by side on Dask workers when there are several.

    Parameters
    ----------
    task
        ``task(split, progress)``: one fold's analysis (picklable).
    sets
        The splits (folds).
    client
        A ``distributed.Client`` to run on (the caller keeps it).
    scheduler
        Else the address of a Dask scheduler to connect to (``tcp://host:8786``).
    workers
        Else the worker processes of the ``LocalCluster`` started (default: the cores, at
        most one per fold); 1, or a single fold, runs every fold in this process, one after
        another.
    progress
        Called with each fold's messages, prefixed by the fold's name, and a line as each
        fold ends.

    Returns
    -------
    list
        The folds' results, in the order of ``sets``.

    Raises
    ------
    Exception
        What a fold's ``task`` raised (on workers, the first fold to fail as they end; the
        others are cancelled).
    KeyboardInterrupt
        Ctrl-C: a cluster thermrs started is shut down at once.
    """
    if client is None and scheduler is None:
        n = min(len(sets), workers or os.cpu_count() or 1)
        if n <= 1:
            return [task(s, prefixed(progress, s.name)) for s in sets]
    from distributed import Client

    from thermrs.campaigns.engine import close_now, local_cluster

    cluster = None
    own = client is None
    if own:
        if scheduler is not None:
            client = Client(scheduler)  # type: ignore[no-untyped-call]
        else:
            cluster = local_cluster(n)
            try:
                client = Client(cluster)  # type: ignore[no-untyped-call]
            except BaseException:
                close_now(cluster)
                raise
    topic = f"thermrs-progress-{uuid.uuid4().hex}"
    if progress is not None:
        say = progress
        client.subscribe_topic(topic, lambda event: say(str(event[1])))
    try:
        return _run(client, task, sets, topic if progress is not None else None, progress)
    finally:
        if progress is not None:
            with suppress(Exception):
                client.unsubscribe_topic(topic)
        if cluster is not None:
            close_now(cluster, client)
        elif own:
            client.close()


def _run(
    client: Any, task: FoldTask[S, R], sets: Sequence[S], topic: str | None, progress: Any
) -> list[R]:
    """Every fold submitted at once, results gathered in order (what is left cancelled when
    one fails or Ctrl-C stops the work)."""
    from distributed import as_completed

    t0 = time.perf_counter()
    futures = [
        client.submit(_on_worker, task, s, topic, pure=False, key=f"fold-{i}-{uuid.uuid4().hex}")
        for i, s in enumerate(sets)
    ]
    names = {f.key: s.name for f, s in zip(futures, sets, strict=True)}
    try:
        for f in as_completed(futures):  # type: ignore[no-untyped-call]
            if f.status == "error":
                f.result()  # raises the fold's own exception
            if progress is not None:
                name = names[f.key]
                progress(f"{name + ': ' if name else ''}done ({time.perf_counter() - t0:.1f} s)")
        return [f.result() for f in futures]
    finally:
        for f in futures:
            if not f.done():
                f.cancel()


def _on_worker(task: FoldTask[S, R], split: S, topic: str | None) -> R:
    """One fold on a worker, its messages sent on ``topic`` (the fold's name before them)."""
    if topic is None:
        return task(split, None)
    from distributed import get_worker

    worker = get_worker()
    return task(split, prefixed(lambda m: worker.log_event(topic, m), split.name))


def prefixed(progress: Progress | None, name: str) -> Progress | None:
    """``progress`` with each message prefixed by the fold's name (as is without one)."""
    if progress is None or not name:
        return progress
    say = progress
    return lambda m: say(f"{name}: {m}")


def run_folds(
    analysis: Callable[..., Any],
    wrap: Callable[[Any, Any], R],
    sets: Sequence[Any],
    rig: Any,
    *,
    client: Any = None,
    scheduler: str | None = None,
    workers: int | None = None,
    progress: Progress | None = None,
    **options: Any,
) -> list[R]:
    """``analysis(split.train, split.holdout, rig, progress=…, **options)`` on every split,
    each result wrapped with its split (:func:`map_folds` runs them).

    Parameters
    ----------
    analysis
        A module-level function of the library taking training runs, held-out runs and the
        rig (:func:`thermrs.diagnose.diagnose`, :func:`thermrs.design.design`).
    wrap
        ``wrap(split, result)``: the fold's result type (a picklable class).
    sets
        The splits, each with ``name``, ``train`` and ``holdout``.
    rig
        The rig.
    client, scheduler, workers, progress
        As :func:`map_folds`.
    **options
        ``analysis``'s keywords.

    Returns
    -------
    list
        One wrapped result per split, in their order.

    Raises
    ------
    Exception
        What ``analysis`` raised for the first split to fail.

    Examples
    --------
    >>> from thermrs.diagnose import diagnose
    >>> from thermrs.analyses.diagnose import DiagnosisFold
    >>> run_folds(diagnose, DiagnosisFold, sets, rig, bootstrap=0)  # doctest: +SKIP
    """
    task = partial(_fold, analysis=analysis, wrap=wrap, rig=rig, **options)
    return map_folds(
        task, sets, client=client, scheduler=scheduler, workers=workers, progress=progress
    )


def _fold(
    split: Any,
    progress: Progress | None,
    *,
    analysis: Callable[..., Any],
    wrap: Callable[[Any, Any], R],
    rig: Any,
    **options: Any,
) -> R:
    """One split's analysis (the task :func:`run_folds` hands :func:`map_folds`)."""
    return wrap(split, analysis(split.train, split.holdout, rig, progress=progress, **options))
