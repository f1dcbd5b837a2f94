"""Results kept by the content of their inputs: within one process (:class:`ContentCache`), and
across runs of a command (:class:`DiskCache`).

A design's proof diagnoses the user's runs again beside each simulated truth, and a report
diagnoses the same runs the design reads: the per-run steps that depend only on a run's own
samples (its heating curves, its de-noised temperatures) are the same each time. A
:class:`ContentCache` keys such a step's result by a digest of the bytes of its inputs (arrays
with their dtype and shape, and scalars), so a result is reused exactly when the inputs are
bit for bit the same, whichever object holds them. It is bounded (least recently used first
out) and safe to share between threads.

A :class:`DiskCache` keeps a whole result (a diagnosis) in a file named by the digest of its
inputs and of the code that computes it, so that ``thermrs diagnose``, then ``thermrs
design`` and ``thermrs report`` on the same runs diagnose them once. Its folder is
``$THERMRS_CACHE_DIR`` (``off`` turns it off), else the user's cache folder
(``platformdirs.user_cache_dir("thermrs")``, ``~/.cache/thermrs`` on Linux). It holds the
:data:`DISK_KEEP` results last used; a file it cannot read is computed again and replaced,
and a folder it cannot write to only means nothing is kept: the cache never changes a result
or fails a command. Its files are pickles, loaded as they are: the folder must be one that
no one else writes to (the user's own cache folder is).
"""

from __future__ import annotations

import contextlib
import functools
import hashlib
import os
import pickle
import threading
from collections import OrderedDict
from collections.abc import Callable
from pathlib import Path
from typing import Generic, TypeVar

import numpy as np

__all__ = [
    "CACHE_ENV",
    "DISK_KEEP",
    "ContentCache",
    "DiskCache",
    "cache_dir",
    "code_identity",
    "content_key",
]

#: The environment variable naming the on-disk cache's folder (``off``: no cache on disk).
CACHE_ENV = "THERMRS_CACHE_DIR"
#: Results a :class:`DiskCache` keeps (the last used); a diagnosis of three 15-h runs is
#: about 0.3 MB.
DISK_KEEP = 64

T = TypeVar("T")


def content_key(*parts: object) -> bytes:
    """A digest of ``parts``: bytes as they are, numpy arrays by dtype, shape and bytes;
    anything else by ``repr``."""
    h = hashlib.blake2b(digest_size=20)
    for p in parts:
        if isinstance(p, bytes):
            h.update(f"bytes {len(p)}".encode())
            h.update(p)
        elif isinstance(p, np.ndarray):
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


def cache_dir() -> Path | None:
    """The on-disk cache's folder: ``$THERMRS_CACHE_DIR`` (None when it is ``off``, ``0`` or
    empty), else the user's cache folder for thermrs."""
    v = os.environ.get(CACHE_ENV)
    if v is not None:
        return None if v.strip().lower() in ("", "0", "off", "no", "false") else Path(v)
    import platformdirs

    return Path(platformdirs.user_cache_dir("thermrs", appauthor=False))


@functools.cache
def code_identity() -> bytes:
    """A digest of the code a cached result came from: thermrs's version and every file of
    the package (name, size, modification time: an edited or rebuilt file changes it), and
    the versions of the libraries that compute with it."""
    from importlib.metadata import version

    root = Path(__file__).parent  # the package's folder
    files = sorted(
        (str(f.relative_to(root)), f.stat().st_size, f.stat().st_mtime_ns)
        for f in root.rglob("*")
        if f.is_file() and "__pycache__" not in f.parts
    )
    libs = [(n, version(n)) for n in ("thermrs", "numpy", "scipy", "polars")]
    return content_key(libs, files)


class DiskCache(Generic[T]):
    """Results on disk by :func:`content_key`, across processes (module docs).

    Parameters
    ----------
    name
        Its subfolder of :func:`cache_dir` (one per kind of result).
    keep
        How many results are kept (the last used).
    """

    def __init__(self, name: str, *, keep: int = DISK_KEEP):
        self.name = name
        self.keep = int(keep)

    def folder(self) -> Path | None:
        """Where its results are (None: the cache is off)."""
        d = cache_dir()
        return None if d is None else d / self.name

    def get(
        self,
        key: bytes,
        compute: Callable[[], T],
        *,
        on_hit: Callable[[Path], object] | None = None,
    ) -> T:
        """The result kept under ``key`` (``on_hit`` called with its file), or ``compute()``
        kept under it. An exception that ``compute`` raises is raised, never kept."""
        folder = self.folder()
        if folder is None:
            return compute()
        path = folder / f"{key.hex()}.pickle"
        try:
            with path.open("rb") as f:
                value: T = pickle.load(f)
        except OSError:
            pass  # none kept, or the folder cannot be read
        except Exception:  # damaged or from another build: computed again and replaced
            with contextlib.suppress(OSError):
                path.unlink(missing_ok=True)
        else:
            try:
                os.utime(path)  # last used
            except OSError:
                pass
            if on_hit is not None:
                on_hit(path)
            return value
        value = compute()
        try:
            folder.mkdir(parents=True, exist_ok=True)
            tmp = folder / f".{key.hex()}.{os.getpid()}.{threading.get_ident()}.tmp"
            with tmp.open("wb") as f:
                pickle.dump(value, f, protocol=pickle.HIGHEST_PROTOCOL)
            os.replace(tmp, path)
            self._prune(folder)
        except Exception:  # nothing kept (a full disk, a read-only folder): never an error
            with contextlib.suppress(OSError, UnboundLocalError):
                tmp.unlink(missing_ok=True)
        return value

    def _prune(self, folder: Path) -> None:
        """The results beyond :attr:`keep`, least recently used first, removed."""
        entries = []
        for f in folder.glob("*.pickle"):
            try:
                entries.append((f.stat().st_mtime_ns, f))
            except OSError:
                continue
        entries.sort(reverse=True)
        for _, f in entries[self.keep :]:
            f.unlink(missing_ok=True)
