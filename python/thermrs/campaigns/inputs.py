"""Moved to :mod:`thermrs.analyses.inputs`; its names stay importable from here."""

from __future__ import annotations

from thermrs.analyses.inputs import (
    DatasetLike,
    Split,
    open_dataset,
    pick_runs,
    select_runs,
    selected,
    splits,
)

__all__ = ["DatasetLike", "Split", "open_dataset", "pick_runs", "select_runs", "selected", "splits"]
