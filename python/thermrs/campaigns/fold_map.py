"""Moved: the fold runner is :mod:`thermrs.analyses.folds`, beside the analyses that run folds.
``thermrs.campaigns.fold_map``'s names still work until thermrs 0.2.0, with a
:class:`DeprecationWarning` that names the new path; this module imports nothing of
:mod:`thermrs.analyses`, which stands above it.
"""

from __future__ import annotations

import warnings
from typing import Any

__all__: list[str] = []

#: The version in which this module, which only hands on names, goes.
MOVED_NAMES_REMOVED_IN = "0.2.0"

#: The names handed on from here, each with the module that defines it now.
MOVED_TO_FOLDS = {
    name: "thermrs.analyses.folds"
    for name in ("Fold", "FoldTask", "Progress", "map_folds", "prefixed")
}


def __getattr__(name: str) -> Any:
    if name in MOVED_TO_FOLDS:
        import importlib

        home = MOVED_TO_FOLDS[name]
        warnings.warn(
            f"thermrs.campaigns.fold_map.{name} moved to {home}.{name}: import it from {home} "
            f"(thermrs.campaigns.fold_map goes in thermrs {MOVED_NAMES_REMOVED_IN})",
            DeprecationWarning,
            stacklevel=2,
        )
        return getattr(importlib.import_module(home), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
