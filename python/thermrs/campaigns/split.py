"""How a campaign's recordings are split into Dask tasks.

A task costs the same whatever it holds: the scheduler's transitions, the messages between
client, scheduler and worker, the result's gather, and the client's share of the commit
loop. Measured on this project's 2-core machine (``benchmarks/bench_campaign_tasks.py``),
a campaign of 24 short recordings (0.13 s of work each)
on 2 workers ran 7 % faster in 8 tasks of 3 recordings than in 24 tasks of one, its client
process using 0.135 s of CPU instead of 0.208 s.
Fewer, larger tasks cost less; but a task is also what a worker loses when it dies, what the
progress bar moves by, and what an interrupted campaign redoes, and the last task decides
how long one worker runs alone at the end. So:

- a campaign gets about :data:`TASKS_PER_SLOT` tasks per worker thread (the last one is then
  a quarter of one worker's share at most), or one task per recording where it has fewer;
- a task holds at most :data:`MAX_TASK_BYTES` of recordings (a fraction of a second to a few
  seconds of extraction), whatever the campaign's size, so that progress, a lost worker and
  an interruption cost at most that;
- the recordings keep the order they are given in (largest first, see
  :func:`thermrs.campaigns.engine.campaign`): each task is a run of consecutive recordings,
  and the tasks are handed out in that order.
"""

from __future__ import annotations

from collections.abc import Sequence

__all__ = ["MAX_TASK_BYTES", "TASKS_PER_SLOT", "split"]

#: Tasks per worker thread that a campaign of many small recordings is split into.
TASKS_PER_SLOT = 4

#: The most bytes of recordings one task holds (a recording larger than this is a task alone).
MAX_TASK_BYTES = 256 << 20


def split(
    sizes: Sequence[int],
    slots: int,
    *,
    tasks_per_slot: int = TASKS_PER_SLOT,
    max_task_bytes: int = MAX_TASK_BYTES,
) -> list[list[int]]:
    """Split recordings (their sizes in bytes, in hand-out order) into tasks.

    Each task's share of the bytes is ``B = min(total / (slots × tasks_per_slot),
    max_task_bytes)``; a recording goes to the task in which the middle of its bytes falls
    (task ``⌊(bytes before it + its size / 2) / B⌋``), so that equal recordings split evenly
    whatever the rounding, and a recording of ``B`` or more bytes is a task alone.

    Parameters
    ----------
    sizes
        The recordings' sizes, in the order they are to be handed out.
    slots
        Worker threads that run tasks at once (at least 1 is assumed).
    tasks_per_slot, max_task_bytes
        See :data:`TASKS_PER_SLOT` and :data:`MAX_TASK_BYTES`.

    Returns
    -------
    list of list of int
        Indices into ``sizes``: consecutive runs, in order, together every index once.

    Examples
    --------
    >>> split([100] * 6, 1)
    [[0], [1, 2], [3], [4, 5]]
    >>> split([100] * 4, 2)
    [[0], [1], [2], [3]]
    """
    if not sizes:
        return []
    total = sum(max(int(s), 0) for s in sizes)
    share = min(total / (max(slots, 1) * max(tasks_per_slot, 1)), float(max_task_bytes))
    if share <= 0:
        return [[i] for i in range(len(sizes))]
    groups: list[list[int]] = []
    last = -1  # the task index of the last group
    held = 0.0  # the bytes of the last group
    before = 0
    for i, raw in enumerate(sizes):
        s = max(int(raw), 0)
        k = int((before + s / 2) // share)
        if groups and k == last and s < share and held < share:
            groups[-1].append(i)
            held += s
        else:
            groups.append([i])
            last, held = k, s
        before += s
    return groups
