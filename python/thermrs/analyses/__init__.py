"""The analyses a user runs — fit, predict, drift, diagnose, design, report — in one place:
each loads its runs once (files or a campaign dataset, :mod:`thermrs.analyses.inputs`), makes
its training and held-out splits, and calls the library. The CLI parses its options, calls
these and renders what they return; a number in the report is the number the command prints.

- :mod:`thermrs.analyses.inputs`: run tables from files (``rec.mcap#run2``) or from a dataset
  (by query and name), :class:`~thermrs.analyses.inputs.Split` (training and held-out runs),
  splits by rule;
- :mod:`thermrs.analyses.fit`: α on training runs (:func:`fit`, :func:`fit_document`), the α a
  prediction uses;
- :mod:`thermrs.analyses.predict`: held-out runs predicted (:func:`predict`,
  :class:`Prediction`, :func:`read_fit_alpha`);
- :mod:`thermrs.analyses.drift`: heating curves and ISO 9283-style figures (:func:`drift`);
- :mod:`thermrs.analyses.diagnose`: a diagnosis per split (:func:`diagnose`);
- :mod:`thermrs.analyses.design`: a design per split (:func:`design`);
- :mod:`thermrs.analyses.baselines`: regressions of the drift on the temperatures beside the
  physical models on the same held-out runs (:func:`compare_baselines`);
- :mod:`thermrs.analyses.report`: a report written (:func:`~thermrs.analyses.report.write_report`),
  the report of a campaign's runs (:func:`report`); its runs read from files
  (:mod:`thermrs.analyses.report_runs`), its numbers built from the analyses above
  (:mod:`thermrs.analyses.report_data`), the demo (:mod:`thermrs.analyses.demo`), each loaded
  when a report is made;
- :mod:`thermrs.analyses.watch`: a run followed while it is recorded (:func:`watch`, a
  generator of :class:`WatchUpdate`).

Each analysis has two forms: ``*_splits`` takes splits however they were made (from a dataset
by :func:`~thermrs.analyses.inputs.splits`, or from files by
:func:`~thermrs.analyses.inputs.file_splits`), and the short form takes a dataset, a query and
a rule or run names.

Example
-------
>>> from thermrs import analyses, load_rig
>>> rig = load_rig("rig.toml")  # doctest: +SKIP
>>> for p in analyses.predict("campaign/", rig, where="speed%>=50", rule="leave-one-run-out"):
...     print(p.split.name, p.alphas["series"], p.table)  # doctest: +SKIP
"""

from __future__ import annotations

from thermrs.analyses.baselines import BaselineComparison, baselines_folds, compare_baselines
from thermrs.analyses.design import DesignFold, design, design_splits
from thermrs.analyses.diagnose import DiagnosisFold, diagnose, diagnose_splits, fold_synthesis
from thermrs.analyses.drift import DriftResult, drift, drift_tables
from thermrs.analyses.fit import FitResult, fit, fit_document, training_alphas, training_axes
from thermrs.analyses.inputs import (
    Split,
    file_splits,
    file_tables,
    read_files,
    selected,
    splits,
)
from thermrs.analyses.predict import (
    Prediction,
    predict,
    predict_splits,
    predict_synthesis,
    read_fit_alpha,
)
from thermrs.analyses.report import report
from thermrs.analyses.watch import WatchUpdate, watch

__all__ = [
    "BaselineComparison",
    "DesignFold",
    "DiagnosisFold",
    "DriftResult",
    "FitResult",
    "Prediction",
    "Split",
    "WatchUpdate",
    "baselines_folds",
    "compare_baselines",
    "design",
    "design_splits",
    "diagnose",
    "diagnose_splits",
    "drift",
    "drift_tables",
    "file_splits",
    "file_tables",
    "fit",
    "fit_document",
    "fold_synthesis",
    "predict",
    "predict_splits",
    "predict_synthesis",
    "read_files",
    "read_fit_alpha",
    "report",
    "selected",
    "splits",
    "training_alphas",
    "training_axes",
    "watch",
]
