"""Moved to :mod:`thermrs.analyses` (one module per analysis); its names stay importable from
here."""

from __future__ import annotations

from thermrs.analyses import (
    DesignFold,
    DiagnosisFold,
    DriftResult,
    Prediction,
    design,
    design_splits,
    diagnose,
    diagnose_splits,
    drift,
    drift_tables,
    fit,
    predict,
    predict_splits,
    report,
)

__all__ = [
    "DesignFold",
    "DiagnosisFold",
    "DriftResult",
    "Prediction",
    "design",
    "design_splits",
    "diagnose",
    "diagnose_splits",
    "drift",
    "drift_tables",
    "fit",
    "predict",
    "predict_splits",
    "report",
]
