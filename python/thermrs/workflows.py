"""Moved to :mod:`thermrs.analyses.fit`; its names stay importable from here."""

from __future__ import annotations

import importlib
from typing import Any

_MOVED = ("FitResult", "fit_document", "training_alphas", "training_axes")


def __getattr__(name: str) -> Any:
    if name in _MOVED:
        return getattr(importlib.import_module("thermrs.analyses.fit"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
