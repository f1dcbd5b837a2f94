"""Campaigns: many recordings extracted into one Parquet dataset, on one machine or a Dask
cluster, and the runs of a campaign chosen by query.

- :mod:`thermrs.campaigns.sources`: paths, globs and folders; content hashes;
- :mod:`thermrs.campaigns.task`: one recording extracted (what a worker runs);
- :mod:`thermrs.campaigns.dataset`: the dataset on disk (partitions, catalog, commits);
- :mod:`thermrs.campaigns.engine`: the campaign run on Dask distributed;
- :mod:`thermrs.campaigns.select`: runs by query, training and held-out sets by rule;
- :mod:`thermrs.campaigns.inputs`: run tables and splits of a dataset, runs by name;
- :mod:`thermrs.campaigns.analyses`: :func:`fit`, :func:`predict`, :func:`drift`,
  :func:`diagnose`, :func:`design` and :func:`report` on a campaign's runs.

Example
-------
>>> import thermrs
>>> res = thermrs.campaign(["recordings/"], "campaign/", rig="rig.toml")  # doctest: +SKIP
>>> res.catalog.select("recording", "runs", "frames", "losses")  # doctest: +SKIP
>>> res.dataset.scan("visits").filter(run="run1").collect()  # doctest: +SKIP
>>> thermrs.campaigns.fit("campaign/", rig, where="date>=2026-11-02").fit  # doctest: +SKIP
>>> for d in thermrs.campaigns.diagnose("campaign/", rig, rule="by-day"):  # doctest: +SKIP
...     print(d.split.name, d.diagnosis.to_json()["verdict"]["status"])
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from typing import Any

from thermrs.campaigns.analyses import (
    DesignFold,
    DiagnosisFold,
    DriftResult,
    Prediction,
    design,
    diagnose,
    drift,
    fit,
    predict,
    report,
)
from thermrs.campaigns.dataset import Dataset
from thermrs.campaigns.engine import CampaignResult, Progress, run_campaign
from thermrs.campaigns.inputs import Split, open_dataset, select_runs, selected, splits
from thermrs.rig import Rig

__all__ = [
    "CampaignResult",
    "Dataset",
    "DesignFold",
    "DiagnosisFold",
    "DriftResult",
    "Prediction",
    "Split",
    "campaign",
    "design",
    "diagnose",
    "drift",
    "fit",
    "open_dataset",
    "predict",
    "report",
    "select_runs",
    "selected",
    "splits",
]


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

    Raises
    ------
    InputError
        A recording name that matches nothing; the dataset folder cannot be made.

    Examples
    --------
    >>> import thermrs
    >>> res = thermrs.campaign(["day1/*.mcap", "day2/"], "campaign")  # doctest: +SKIP
    >>> res.extracted, res.unchanged, res.dashboard  # doctest: +SKIP
    >>> res.dataset.scan("visits").filter(run="run2").collect()  # doctest: +SKIP
    """
    return run_campaign(
        recordings,
        out,
        rig=rig,
        client=client,
        scheduler=scheduler,
        workers=workers,
        visit_tolerance_deg=visit_tolerance_deg,
        progress=progress,
        on_cluster=on_cluster,
    )
