"""Outputs written atomically (SPEC §7): to a temporary file beside the target, then renamed
over it; a failure or Ctrl-C leaves the target as it was and no temporary behind.

Bad input stays :class:`~thermrs.errors.InputError` (a folder that does not exist, a folder
given for a file; the CLI exits 2). A write the system refuses (a read-only folder, a full
disk, a file system that takes no file such as ``/proc``) is an
:class:`~thermrs.errors.OutputError` naming the file asked for, never the temporary one (the
CLI exits 1 with ``error: cannot write PATH: reason``).

Ctrl-C is deferred while temporaries are created, so that none is left behind between its
creation and the ``try`` that removes it (:func:`hold_interrupts`).
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import tempfile
import threading
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from thermrs.errors import InputError, OutputError

if TYPE_CHECKING:  # pragma: no cover
    import polars as pl

__all__ = [
    "atomic_tmp",
    "check_writable",
    "hold_interrupts",
    "publish",
    "release_interrupts",
    "write_all",
    "write_atomic",
    "write_csv",
    "write_dir",
    "write_failed",
    "write_json",
    "write_parquet_atomic",
    "write_text",
]


def write_failed(
    e: BaseException, path: str | Path, *, tmp: str | Path | None = None
) -> OutputError:
    """A failed write as an :class:`~thermrs.errors.OutputError` naming ``path``: the
    operating system's error (errno and reason) as it is, or the writer's first line (polars'
    writers lose the errno), without a ``cannot write TMP:`` the writer put before it."""
    if isinstance(e, OutputError):
        return e
    reason = (e.strerror if isinstance(e, OSError) else None) or str(e).strip()
    reason = (reason.splitlines() or [type(e).__name__])[0]
    if tmp is not None:
        reason = reason.removeprefix(f"cannot write {tmp}: ")
    errno = e.errno if isinstance(e, OSError) else None
    return OutputError(errno, reason, str(path))


def check_writable(path: str | Path, *, what: str = "output") -> Path:
    """Check, before any work, that ``path`` can be written atomically: its folder exists and
    takes a new file, and ``path`` itself is not a folder.

    Parameters
    ----------
    path
        The file to be written.
    what
        How messages of bad input name it (e.g. ``"-o"``).

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    InputError
        ``path`` is a folder, or its folder does not exist: one line naming ``path``.
    OutputError
        The folder takes no new file (read-only, ``/proc``): ``cannot write PATH: reason``.

    Examples
    --------
    >>> from thermrs.atomic import check_writable
    >>> check_writable("/no/such/folder/x.parquet", what="-o")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    thermrs._native.InputError: -o ...: folder /no/such/folder does not exist (create it first)
    """
    path = Path(path)
    if path.is_dir():
        raise InputError(f"{what} {path}: is a directory, expected a file name")
    parent = path.parent
    if not parent.exists():
        raise InputError(f"{what} {path}: folder {parent} does not exist (create it first)")
    if not parent.is_dir():
        raise InputError(f"{what} {path}: {parent} is not a folder")
    # An unnamed file (O_TMPFILE where the filesystem has it): nothing is left behind when
    # Ctrl-C lands here, as it could between creating and removing a named one.
    try:
        with tempfile.TemporaryFile(dir=parent):
            pass
    except OSError as e:
        raise write_failed(e, path) from None
    return path


def atomic_tmp(path: Path, *, what: str = "cannot write") -> Path:
    """A fresh temporary file beside ``path`` (same filesystem, so the rename is atomic).

    Raises
    ------
    InputError
        The folder does not exist.
    OutputError
        The folder takes no new file.
    """
    if not path.parent.is_dir():
        raise InputError(f"{what} {path}: folder {path.parent} does not exist (create it first)")
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    except OSError as e:
        raise write_failed(e, path) from None
    os.close(fd)
    return Path(tmp)


def _created_mode(mode: int) -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mode & ~mask


def publish(tmp: Path, path: Path) -> None:
    """Give ``tmp`` the permissions a newly created file gets (mkstemp makes it private),
    then rename it onto ``path`` in one step."""
    try:
        os.chmod(tmp, _created_mode(0o666))
        os.replace(tmp, path)
    except OSError as e:
        raise write_failed(e, path) from None


class _Held:
    """SIGINT deferred: the handler to restore and whether one arrived meanwhile."""

    def __init__(self, previous: Any) -> None:
        self.previous = previous
        self.pending = False
        self.active = True

    def defer(self, signum: int, frame: object) -> None:
        self.pending = True


def hold_interrupts() -> _Held | None:
    """Defer Ctrl-C (in the main thread, where Python runs signal handlers).

    Between creating a temporary file and entering the ``try`` that removes it, a Ctrl-C would
    leave it behind: creation happens with SIGINT deferred, and :func:`release_interrupts`
    inside the ``try`` raises a deferred one where the cleanup sees it. (Blocking the signal
    in this thread would not do: the kernel hands a process-directed SIGINT to another thread,
    and Python still runs the handler here.)"""
    if threading.current_thread() is not threading.main_thread():
        return None
    previous = signal.getsignal(signal.SIGINT)
    if not callable(previous):  # ignored or default: nothing of Python's to defer
        return None
    held = _Held(previous)
    signal.signal(signal.SIGINT, held.defer)
    return held


def release_interrupts(held: _Held | None) -> None:
    """Restore the handler :func:`hold_interrupts` replaced and deliver a deferred Ctrl-C to
    it (idempotent)."""
    if held is None or not held.active:
        return
    held.active = False
    signal.signal(signal.SIGINT, held.previous)
    if held.pending:
        held.previous(signal.SIGINT, None)


def write_all(writers: Mapping[Path, Callable[[Path], object]]) -> None:
    """All or nothing: each ``writer(tmp)`` writes a temporary beside its path, then every
    temporary is renamed onto its path; an error or Ctrl-C on the way removes what this call
    wrote (temporaries and files already renamed).

    Raises
    ------
    InputError
        A folder does not exist.
    OutputError
        A write failed (an ``OSError`` of a writer, or of polars'), naming the file.
    """
    tmps: dict[Path, Path] = {}
    published: list[Path] = []
    held = hold_interrupts()  # no Ctrl-C between creating a temporary and knowing it
    try:
        for path in writers:
            tmps[path] = atomic_tmp(path)
        release_interrupts(held)  # a Ctrl-C pending since lands here, inside the try
        for path, write in writers.items():
            try:
                write(tmps[path])
            except Exception as e:
                if isinstance(e, OSError) or _is_polars_error(e):
                    raise write_failed(e, path, tmp=tmps[path]) from None
                raise
        for path, tmp in tmps.items():
            publish(tmp, path)
            published.append(path)
    except BaseException:
        for t in tmps.values():
            t.unlink(missing_ok=True)
        for p in published:
            p.unlink(missing_ok=True)
        raise
    finally:
        release_interrupts(held)


def _is_polars_error(e: BaseException) -> bool:
    import polars as pl

    return isinstance(e, pl.exceptions.PolarsError)


def write_atomic(path: Path, write: Callable[[Path], object]) -> None:
    """Call ``write(tmp)`` and publish ``tmp`` as ``path``; remove ``tmp`` on any failure."""
    write_all({Path(path): write})


def write_text(path: Path, text: str) -> None:
    """``text`` (UTF-8) to ``path``, atomically."""
    write_atomic(path, lambda tmp: tmp.write_text(text, encoding="utf-8"))


def write_json(path: Path, doc: object) -> None:
    """``doc`` as indented JSON to ``path``, atomically."""
    write_text(path, json.dumps(doc, indent=2))


def write_csv(path: Path, df: pl.DataFrame) -> None:
    """``df`` as CSV to ``path``, atomically."""
    write_atomic(path, df.write_csv)


def write_parquet_atomic(
    df: pl.DataFrame, path: str | Path, *, metadata: dict[str, str] | None = None
) -> None:
    """Write ``df`` to ``path`` through a temporary file in the same folder, then rename: a
    reader never sees a half-written file, and a failure leaves the old file in place.

    Parameters
    ----------
    df
        The table.
    path
        Where to write it; its folder must exist (it is not created).
    metadata
        Parquet key-value metadata to store with the table.

    Raises
    ------
    InputError
        The folder does not exist.
    OutputError
        Writing failed (a read-only folder, a full disk); the message names ``path``; nothing
        is left behind.

    Examples
    --------
    >>> import polars as pl
    >>> from thermrs.ingest import write_parquet_atomic
    >>> write_parquet_atomic(pl.DataFrame({"x": [1]}), "out/x.parquet")  # doctest: +SKIP
    """
    write_atomic(Path(path), lambda tmp: df.write_parquet(tmp, metadata=metadata))


def write_dir(path: Path, write: Callable[[Path], object]) -> None:
    """A folder written whole: ``write(staging)`` fills a fresh folder beside ``path``, which
    then replaces ``path`` (the old folder removed first); a failure or Ctrl-C removes the
    staging folder.

    Raises
    ------
    OutputError
        The folder or a file in it could not be written, naming ``path``.
    """
    held = hold_interrupts()
    staging: Path | None = None
    try:
        try:
            staging = Path(tempfile.mkdtemp(prefix=f".{path.name}.", dir=path.parent))
        except OSError as e:
            raise write_failed(e, path) from None
        release_interrupts(held)
        try:
            write(staging)
            if path.exists():
                shutil.rmtree(path)
            staging.rename(path)
            os.chmod(path, _created_mode(0o777))  # mkdtemp makes it private
        except OSError as e:
            raise write_failed(e, path) from None
    except BaseException:
        if staging is not None:
            shutil.rmtree(staging, ignore_errors=True)
        raise
    finally:
        release_interrupts(held)
