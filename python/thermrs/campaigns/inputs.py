"""Moved to :mod:`thermrs.analyses.inputs`; its names stay importable from here."""

from __future__ import annotations

import importlib
from typing import Any

_MOVED = ("DatasetLike", "Split", "open_dataset", "pick_runs", "select_runs", "selected", "splits")


def __getattr__(name: str) -> Any:
    if name in _MOVED:
        return getattr(importlib.import_module("thermrs.analyses.inputs"), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
