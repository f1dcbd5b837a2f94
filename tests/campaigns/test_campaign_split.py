"""How a campaign's recordings are split into Dask tasks (:mod:`thermrs.campaigns.split`):
against hand-worked splits and the rule's promises on random campaigns."""

from __future__ import annotations

import numpy as np
import pytest
from thermrs.campaigns.split import MAX_TASK_BYTES, TASKS_PER_SLOT, split

MIB = 1 << 20


def test_equal_recordings_split_evenly() -> None:
    """24 equal recordings on 2 workers: 8 tasks (4 per worker) of 3, in order; on 1 worker,
    4 tasks of 6 (recordings small enough that a task stays below the cap); fewer recordings
    than tasks wanted: one task each."""
    assert split([54 * MIB] * 24, 2) == [[3 * k, 3 * k + 1, 3 * k + 2] for k in range(8)]
    assert split([10 * MIB] * 24, 1) == [list(range(6 * k, 6 * k + 6)) for k in range(4)]
    assert split([54 * MIB] * 6, 2) == [[i] for i in range(6)]
    assert split([], 2) == []
    assert split([0, 0, 0], 2) == [[0], [1], [2]]


def test_a_recording_of_a_share_or_more_is_alone() -> None:
    """One 1,000-byte recording before thirty of 10 bytes on 2 workers (a share is
    1,300 / 8 = 162.5 bytes): the large one alone, the small ones in runs by where their
    middles fall: 1005 … 1135 in share 6 (975–1137.5), 1145 … 1295 in share 7."""
    assert split([1000] + [10] * 30, 2) == [[0], list(range(1, 15)), list(range(15, 31))]


def test_a_task_holds_at_most_the_cap() -> None:
    """A month of small recordings on 2 workers is not 8 huge tasks: each holds at most
    256 MiB plus one recording."""
    sizes = [5 * MIB] * 2000
    tasks = split(sizes, 2)
    assert max(sum(sizes[i] for i in t) for t in tasks) <= MAX_TASK_BYTES + 5 * MIB
    assert len(tasks) >= 2000 * 5 * MIB // (MAX_TASK_BYTES + 5 * MIB)


@pytest.mark.parametrize("seed", range(20))
def test_every_recording_once_in_order(seed: int) -> None:
    """On random campaigns (log-uniform sizes from 1 MiB to 4 GiB, largest first, 1–64
    slots): the tasks are consecutive runs that together hold every recording once; a task
    of several recordings holds less than two shares, and only recordings of less than one;
    so the recordings of less than a share make at least (their bytes / two shares) tasks."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 400))
    sizes = sorted((int(2 ** rng.uniform(20, 32)) for _ in range(n)), reverse=True)
    slots = int(rng.integers(1, 65))
    tasks = split(sizes, slots)
    assert [i for t in tasks for i in t] == list(range(n))
    share = min(sum(sizes) / (slots * TASKS_PER_SLOT), MAX_TASK_BYTES)
    for t in tasks:
        if len(t) > 1:
            assert sum(sizes[i] for i in t) < 2 * share
            assert all(sizes[i] < share for i in t)
    small = [t for t in tasks if sizes[t[0]] < share]
    assert len(small) >= sum(s for s in sizes if s < share) / (2 * share)
