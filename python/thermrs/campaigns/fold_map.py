"""Moved: the fold runner is :mod:`thermrs.analyses.folds`, beside the analyses that run folds.
``thermrs.campaigns.fold_map``'s names still work until thermrs 0.2.0, with a
:class:`DeprecationWarning` that names the new path; this module imports nothing of
:mod:`thermrs.analyses`, which stands above it.
"""

from __future__ import annotations

from thermrs.moved import handed_on

__all__: list[str] = []


#: The names handed on from here, each with the module that defines it now.
MOVED_TO_FOLDS = {
    name: "thermrs.analyses.folds"
    for name in ("Fold", "FoldTask", "Progress", "map_folds", "prefixed")
}


__getattr__ = handed_on("thermrs.campaigns.fold_map", MOVED_TO_FOLDS, whole_module=True)
