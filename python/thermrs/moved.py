"""Names that moved, handed on from their old module until the version that removes them, with
a :class:`DeprecationWarning` that names the new path (PEP 562 ``__getattr__``). The old
module imports nothing of the new one until a moved name is asked for, so a module may hand
on names of a package that stands above it.
"""

from __future__ import annotations

import importlib
import warnings
from collections.abc import Callable, Mapping
from typing import Any

__all__ = ["MOVED_NAMES_REMOVED_IN", "handed_on"]

#: The version in which every moved name stops being handed on.
MOVED_NAMES_REMOVED_IN = "0.2.0"


def handed_on(
    module: str, moved: Mapping[str, str], *, whole_module: bool = False
) -> Callable[[str], Any]:
    """A module's ``__getattr__`` that hands on each name of ``moved`` from its new module.

    Parameters
    ----------
    module
        The old module's name (``thermrs.campaigns``).
    moved
        Each moved name with the module that defines it now.
    whole_module
        The old module goes as a whole in :data:`MOVED_NAMES_REMOVED_IN` (the warning says
        so), not only the names.

    Returns
    -------
    callable
        ``__getattr__(name)``: the name from its new module, with a warning naming the new
        path; :class:`AttributeError` for any other name.

    Raises
    ------
    AttributeError
        Raised by the function returned, for a name that did not move here.

    Examples
    --------
    >>> __getattr__ = handed_on("thermrs.diagnose.bench", {"run_bench": "thermrs.bench"})
    """
    goes = "{module}" if whole_module else "{module}.{name}"

    def __getattr__(name: str) -> Any:
        if name not in moved:
            raise AttributeError(f"module {module!r} has no attribute {name!r}")
        home = moved[name]
        old = goes.format(module=module, name=name)
        warnings.warn(
            f"{module}.{name} moved to {home}.{name}: import it from {home} "
            f"({old} goes in thermrs {MOVED_NAMES_REMOVED_IN})",
            DeprecationWarning,
            stacklevel=2,
        )
        return getattr(importlib.import_module(home), name)

    return __getattr__
