"""Campaigns: many recordings extracted into one Parquet dataset, on one machine or a Dask
cluster, and the runs of a campaign chosen by query.

- :mod:`thermrs.campaigns.sources`: paths, globs and folders; content hashes;
- :mod:`thermrs.campaigns.task`: one recording extracted (what a worker runs);
- :mod:`thermrs.campaigns.dataset`: the dataset on disk (partitions, catalog, commits);
- :mod:`thermrs.campaigns.split`: the recordings split into Dask tasks;
- :mod:`thermrs.campaigns.engine`: the campaign run on Dask distributed;
- :mod:`thermrs.campaigns.select`: runs by query, training and held-out sets by rule;
- :mod:`thermrs.campaigns.summary`: α per run, its trend, per day and per speed, folds
  concluded.

:func:`fit`, :func:`predict`, :func:`drift`, :func:`diagnose`, :func:`design` and
:func:`report` on a campaign's runs, and :func:`selected`, :func:`splits`,
:func:`select_runs`, :func:`open_dataset`, are those of :mod:`thermrs.analyses` (where every
analysis runs, on files and on datasets alike), reachable from here.

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

from typing import Any

from thermrs.campaigns import summary
from thermrs.campaigns.dataset import Dataset
from thermrs.campaigns.engine import CampaignInterrupted, CampaignResult, campaign

#: Names that live in :mod:`thermrs.analyses`, by the module that holds them.
_ANALYSES = {
    "DesignFold": "design",
    "DiagnosisFold": "diagnose",
    "DriftResult": "drift",
    "Prediction": "predict",
    "Split": "inputs",
    "design": "design",
    "diagnose": "diagnose",
    "drift": "drift",
    "fit": "fit",
    "open_dataset": "inputs",
    "predict": "predict",
    "report": "report",
    "select_runs": "inputs",
    "selected": "inputs",
    "splits": "inputs",
}


def __getattr__(name: str) -> Any:
    # Read when first asked: thermrs.analyses imports this package's modules.
    if name in _ANALYSES:
        import importlib

        return getattr(importlib.import_module(f"thermrs.analyses.{_ANALYSES[name]}"), name)
    if name in ("analyses", "inputs"):
        import importlib

        return importlib.import_module(f"thermrs.campaigns.{name}")
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


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
