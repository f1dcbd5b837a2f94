"""Moved: the bench is :mod:`thermrs.bench` (its world :mod:`thermrs.bench.world`), beside the
diagnoser it tests rather than inside it. ``thermrs.diagnose.bench.run_bench`` and
``.make_runs`` still work until thermrs 0.2.0, with a :class:`DeprecationWarning` that names the
new path; this module imports nothing of :mod:`thermrs.bench`, which stands above it.
"""

from __future__ import annotations

import warnings
from typing import Any

__all__: list[str] = []

#: The version in which this module, which only hands on names, goes.
MOVED_NAMES_REMOVED_IN = "0.2.0"

#: The names handed on from here, each with the module that defines it now.
MOVED_TO_BENCH = {"make_runs": "thermrs.bench", "run_bench": "thermrs.bench"}


def __getattr__(name: str) -> Any:
    if name in MOVED_TO_BENCH:
        import importlib

        home = MOVED_TO_BENCH[name]
        warnings.warn(
            f"thermrs.diagnose.bench.{name} moved to {home}.{name}: import it from {home} "
            f"(thermrs.diagnose.bench goes in thermrs {MOVED_NAMES_REMOVED_IN})",
            DeprecationWarning,
            stacklevel=2,
        )
        return getattr(importlib.import_module(home), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
