"""Campaigns: many recordings extracted into one Parquet dataset, on one machine or a Dask
cluster, and the runs of a campaign chosen by query.

- :mod:`thermrs.campaigns.sources`: paths, globs and folders; content hashes;
- :mod:`thermrs.campaigns.task`: one recording extracted (what a worker runs);
- :mod:`thermrs.campaigns.dataset`: the dataset on disk (partitions, catalog, commits);
- :mod:`thermrs.campaigns.split`: the recordings split into Dask tasks;
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

from thermrs.campaigns import summary
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
from thermrs.campaigns.engine import CampaignInterrupted, CampaignResult, campaign
from thermrs.campaigns.inputs import Split, open_dataset, select_runs, selected, splits

__all__ = [
    "CampaignInterrupted",
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
    "summary",
]
