"""Moved: the bench is :mod:`thermrs.bench` (its world :mod:`thermrs.bench.world`), beside the
diagnoser it tests rather than inside it. ``thermrs.diagnose.bench.run_bench`` and
``.make_runs`` still work until thermrs 0.2.0, with a :class:`DeprecationWarning` that names the
new path; this module imports nothing of :mod:`thermrs.bench`, which stands above it.
"""

from __future__ import annotations

from thermrs.moved import handed_on

__all__: list[str] = []


#: The names handed on from here, each with the module that defines it now.
MOVED_TO_BENCH = {"make_runs": "thermrs.bench", "run_bench": "thermrs.bench"}


__getattr__ = handed_on("thermrs.diagnose.bench", MOVED_TO_BENCH, whole_module=True)
