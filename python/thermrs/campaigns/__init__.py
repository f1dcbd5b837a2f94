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

The analyses on a campaign's runs (fit, predict, drift, diagnose, design, the report) live in
:mod:`thermrs.analyses`, where every analysis runs, on files and on datasets alike:
``thermrs.analyses.fit(dataset, rig, where=…)``. Their old names here
(``thermrs.campaigns.fit``, …) still work until thermrs 0.2.0, with a
:class:`DeprecationWarning` that names the new path.

Example
-------
>>> import thermrs
>>> res = thermrs.campaign(["recordings/"], "campaign/", rig="rig.toml")  # doctest: +SKIP
>>> res.catalog.select("recording", "runs", "frames", "losses")  # doctest: +SKIP
>>> res.dataset.scan("visits").filter(run="run1").collect()  # doctest: +SKIP
>>> thermrs.analyses.fit("campaign/", rig, where="date>=2026-11-02").fit  # doctest: +SKIP
"""

from __future__ import annotations

from thermrs.campaigns import summary
from thermrs.campaigns.dataset import Dataset
from thermrs.campaigns.engine import CampaignInterrupted, CampaignResult, campaign
from thermrs.moved import handed_on

__all__ = ["CampaignInterrupted", "CampaignResult", "Dataset", "campaign", "summary"]


#: Names that moved to :mod:`thermrs.analyses`, each with the module that exports it there.
#: Handed on when first asked, with a warning: this package sits below :mod:`thermrs.analyses`
#: (which imports its modules) and imports nothing of it.
_TO_ANALYSES = ("DesignFold", "DiagnosisFold", "DriftResult", "Prediction", "Split", "design",
                "diagnose", "drift", "fit", "predict", "report", "selected", "splits")  # fmt: skip
MOVED_TO_ANALYSES = {
    **dict.fromkeys(_TO_ANALYSES, "thermrs.analyses"),
    "open_dataset": "thermrs.analyses.inputs",
    "select_runs": "thermrs.analyses.inputs",
}


__getattr__ = handed_on("thermrs.campaigns", MOVED_TO_ANALYSES)
