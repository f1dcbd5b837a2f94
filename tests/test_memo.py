"""Results kept by content: the same bytes give the kept result whatever object holds them;
any other bytes, dtype, shape or scalar do not; a failure is kept as a failure."""

from __future__ import annotations

import numpy as np
import pytest
from thermrs.memo import ContentCache, content_key


def test_a_result_is_kept_by_the_content_of_its_inputs() -> None:
    cache: ContentCache[float] = ContentCache(8)
    calls = []

    def total(a: np.ndarray) -> float:
        calls.append(1)
        return float(a.sum())

    a = np.arange(10.0)
    assert cache.get(content_key(a, 1.5), lambda: total(a)) == 45.0
    b = a.copy()  # another object, the same bytes
    assert cache.get(content_key(b, 1.5), lambda: total(b)) == 45.0
    assert len(calls) == 1
    for other in (
        content_key(a[::-1].copy(), 1.5),  # other bytes
        content_key(a.astype(np.float32), 1.5),  # other dtype
        content_key(a.reshape(2, 5), 1.5),  # other shape
        content_key(a, 1.25),  # other scalar
    ):
        assert other != content_key(a, 1.5)


def test_a_failure_is_kept_and_the_oldest_result_leaves_first() -> None:
    cache: ContentCache[int] = ContentCache(2)

    def fail() -> int:
        raise ValueError("no fit")

    with pytest.raises(ValueError, match="no fit"):
        cache.get(b"k", fail)
    with pytest.raises(ValueError, match="no fit"):
        cache.get(b"k", lambda: 1)  # kept: not computed again
    cache.get(b"a", lambda: 2)
    cache.get(b"b", lambda: 3)  # "k" leaves
    assert cache.get(b"k", lambda: 4) == 4
    assert cache.misses == 4 and cache.hits == 1
