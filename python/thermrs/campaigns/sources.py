"""The recordings of a campaign: paths, globs and folders expanded, and their content hashes.

A campaign names its recordings as the user types them: files, glob patterns (``'day*/r*.mcap'``,
expanded here, also where the shell did not) and folders (every ``*.mcap`` below them). Each
recording is identified by the BLAKE3 hash of its bytes (``content_hash``), so that a file
renamed, copied or touched is known for what it holds; its id in the dataset is
``<stem>-<first 12 hex digits of the hash>`` (readable, and stable between campaigns).
"""

from __future__ import annotations

import glob
import os
from dataclasses import dataclass
from pathlib import Path

from thermrs.errors import InputError

__all__ = ["Source", "content_hash", "expand", "recording_id"]


@dataclass(frozen=True)
class Source:
    """One recording of a campaign, as found on disk.

    Attributes
    ----------
    path
        The file (absolute, unless :func:`expand` was asked for the paths as named).
    size_bytes, mtime_ns
        From ``stat``: with the path, the key under which a previous campaign's hash of the
        file is trusted without reading the file again.
    """

    path: Path
    size_bytes: int
    mtime_ns: int


def expand(
    specs: list[str] | tuple[str, ...] | list[Path], *, resolve: bool = True
) -> list[Source]:
    """The recordings named by ``specs``, each once, in the order first named.

    Parameters
    ----------
    specs
        Files, glob patterns (``*``, ``?``, ``[…]``, ``**``) and folders (every ``*.mcap``
        below them, sorted).
    resolve
        Give each recording's absolute path (a campaign's key); else its path as named (a
        file as given, a folder's or pattern's files below it as written). A file named
        twice is found once either way.

    Raises
    ------
    InputError
        A name that matches nothing, or no recording at all; the message names it.
    """
    seen: set[Path] = set()
    out: list[Source] = []
    for spec in specs:
        s = str(spec)
        if Path(s).is_dir():
            found = sorted(Path(s).rglob("*.mcap"))
            if not found:
                raise InputError(f"recording folder {s}: holds no .mcap file")
        elif Path(s).exists():
            found = [Path(s)]
        elif glob.has_magic(s):
            found = sorted(Path(p) for p in glob.glob(s, recursive=True) if Path(p).is_file())
            if not found:
                raise InputError(f"recordings {s!r}: the pattern matches no file")
        else:
            raise InputError(f"recording {s}: no such file")
        for named in found:
            p = named.resolve()
            if p in seen:
                continue
            seen.add(p)
            try:
                st = p.stat()
            except OSError as e:
                raise InputError(f"recording {p}: {e.strerror or e}") from None
            out.append(Source(p if resolve else named, st.st_size, st.st_mtime_ns))
    if not out:
        raise InputError("no recording given")
    return out


def content_hash(path: str | os.PathLike[str]) -> str:
    """The hash (hex) that identifies a recording: BLAKE3 of the file's bytes, a trailing hole
    (space a crashed writer reserved) counted by its length rather than read; the same as an
    extraction's own pass gives (``extract(..., content_hash=True)``). Read in the core with
    the GIL released.

    Raises
    ------
    InputError
        The file cannot be read.
    """
    import thermrs._native as _native

    return _native.content_hash(os.fspath(path))


def recording_id(path: str | os.PathLike[str], digest: str) -> str:
    """The recording's id in a campaign dataset: file stem and the hash's first 12 hex digits."""
    name = Path(path).name
    stem = name[: -len(".mcap")] if name.endswith(".mcap") else Path(name).stem
    return f"{stem}-{digest[:12]}"
