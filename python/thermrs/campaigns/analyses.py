"""Moved to :mod:`thermrs.analyses` (one module per analysis); its names stay importable from
here."""

from __future__ import annotations

import importlib
from typing import Any

_MOVED = (
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
)


def __getattr__(name: str) -> Any:
    if name in _MOVED:
        return getattr(importlib.import_module("thermrs.analyses"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
