"""Two JSON-like documents compared: the same keys, lists and strings, numbers equal within a
relative tolerance (NaN equal to NaN)."""

from __future__ import annotations

import math
from typing import Any


def assert_nested_close(a: Any, b: Any, *, rel: float = 1e-9, where: str = "") -> None:
    """Assert ``a`` and ``b`` are the same document, numbers within ``rel`` (and 1e-12)."""
    if isinstance(a, dict) and isinstance(b, dict):
        assert a.keys() == b.keys(), f"{where}: keys {sorted(a)} against {sorted(b)}"
        for k in a:
            assert_nested_close(a[k], b[k], rel=rel, where=f"{where}.{k}")
    elif isinstance(a, list | tuple) and isinstance(b, list | tuple):
        assert len(a) == len(b), f"{where}: {len(a)} items against {len(b)}"
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            assert_nested_close(x, y, rel=rel, where=f"{where}[{i}]")
    elif (
        isinstance(a, int | float)
        and isinstance(b, int | float)
        and not isinstance(a, bool)
        and not isinstance(b, bool)
    ):
        same = (math.isnan(a) and math.isnan(b)) or math.isclose(a, b, rel_tol=rel, abs_tol=1e-12)
        assert same, f"{where}: {a!r} against {b!r}"
    else:
        assert a == b, f"{where}: {a!r} against {b!r}"
