"""Results kept by the content of their inputs, within one process.

A design's proof diagnoses the user's runs again beside each simulated truth, and a report
diagnoses the same runs the design reads: the per-run steps that depend only on a run's own
samples (its heating curves, its de-noised temperatures) are the same each time. A
:class:`ContentCache` keys such a step's result by a digest of the bytes of its inputs (arrays
with their dtype and shape, and scalars), so a result is reused exactly when the inputs are
bit for bit the same, whichever object holds them. It is bounded (least recently used first
out) and safe to share between threads.
"""

from __future__ import annotations

import hashlib
import threading
from collections import OrderedDict
from collections.abc import Callable
from typing import Generic, TypeVar

import numpy as np

__all__ = ["ContentCache", "content_key"]

T = TypeVar("T")


def content_key(*parts: object) -> bytes:
    """A digest of ``parts``: numpy arrays by dtype, shape and bytes; anything else by
    ``repr``."""
    h = hashlib.blake2b(digest_size=20)
    for p in parts:
        if isinstance(p, np.ndarray):
            a = np.ascontiguousarray(p)
            h.update(f"array {a.dtype.str} {a.shape}".encode())
            h.update(a.tobytes())
        else:
            h.update(f"value {p!r}".encode())
        h.update(b"\0")
    return h.digest()


class ContentCache(Generic[T]):
    """At most ``size`` results by :func:`content_key` of their inputs.

    Parameters
    ----------
    size
        How many results are kept.
    """

    def __init__(self, size: int):
        self.size = int(size)
        self._items: OrderedDict[bytes, tuple[bool, object]] = OrderedDict()
        self._lock = threading.Lock()
        self.hits = 0
        self.misses = 0

    def get(self, key: bytes, compute: Callable[[], T]) -> T:
        """The result kept under ``key``, or ``compute()`` kept under it. An exception that
        ``compute`` raises is kept too, and raised again for the same inputs."""
        with self._lock:
            hit = self._items.get(key)
            if hit is not None:
                self._items.move_to_end(key)
                self.hits += 1
        if hit is None:
            self.misses += 1
            try:
                hit = (True, compute())
            except Exception as e:  # kept: the same inputs fail the same way
                hit = (False, e)
            with self._lock:
                self._items[key] = hit
                while len(self._items) > self.size:
                    self._items.popitem(last=False)
        ok, value = hit
        if not ok:
            assert isinstance(value, Exception)
            raise value
        return value  # type: ignore[return-value]

    def clear(self) -> None:
        """Forget every result."""
        with self._lock:
            self._items.clear()
