"""The recordings of a campaign: paths, globs and folders expanded, and their content hashes.

A campaign names its recordings as the user types them: files, glob patterns (``'day*/r*.mcap'``,
expanded here, also where the shell did not) and folders (every recording below them: ``*.mcap``
and ``*.db3`` files, either compressed whole as ``*.zstd``, ROS 1 ``*.bag`` files, and rosbag2
bag folders, each bag
one recording; a folder that is itself a bag is one recording). Each recording is identified by
the BLAKE3 hash of its bytes (``content_hash``; a bag: of its files' hashes in order), so that a
file renamed, copied or touched is known for what it holds; its id in the dataset is
``<stem>-<first 12 hex digits of the hash>`` (readable, and stable between campaigns).
"""

from __future__ import annotations

import glob
import os
from dataclasses import dataclass
from pathlib import Path

from thermrs.errors import InputError
from thermrs.ingest import stat_of

__all__ = ["RECORDING_SUFFIXES", "Source", "content_hash", "expand", "recording_id", "stat_of"]

#: The names of the files a folder's recordings are found by (a bag folder is found by its
#: ``metadata.yaml`` or its numbered files).
RECORDING_SUFFIXES = (".mcap", ".db3", ".mcap.zstd", ".db3.zstd", ".bag")


@dataclass(frozen=True)
class Source:
    """One recording of a campaign, as found on disk.

    Attributes
    ----------
    path
        The file or bag folder (absolute, unless :func:`expand` was asked for the paths as
        named).
    size_bytes, mtime_ns
        From ``stat`` (a bag: its files' sizes summed, the latest modification of them and
        its ``metadata.yaml``): with the path, the key under which a previous campaign's hash
        of the recording is trusted without reading it again.
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
        Files, glob patterns (``*``, ``?``, ``[…]``, ``**``) and folders (every recording
        below them, sorted: see the module docs).
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
            found = recordings_below(Path(s))
            if not found:
                raise InputError(
                    f"recording folder {s}: holds no recording "
                    f"({', '.join(RECORDING_SUFFIXES)} or a rosbag2 bag folder)"
                )
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
            size, mtime = stat_of(p)
            out.append(Source(p if resolve else named, size, mtime))
    if not out:
        raise InputError("no recording given")
    return out


def recordings_below(folder: Path) -> list[Path]:
    """The recordings in ``folder`` and below it, sorted: the folder itself if it is a bag,
    else each bag folder below it (not looked into further) and each recording file."""
    import thermrs._native as _native

    if _native.is_bag(str(folder)):
        return [folder]
    found: list[Path] = []
    for here, dirs, files in os.walk(folder):
        if Path(here) != folder and _native.is_bag(here):
            found.append(Path(here))
            dirs.clear()
            continue
        found += [Path(here) / f for f in files if f.endswith(RECORDING_SUFFIXES)]
    return sorted(found)


def content_hash(path: str | os.PathLike[str]) -> str:
    """The hash (hex) that identifies a recording: BLAKE3 of the file's bytes, a trailing hole
    (space a crashed writer reserved) counted by its length rather than read; for a bag
    folder, BLAKE3 of its files' names and hashes in order (a missing file counted as such);
    the same as an extraction's own pass gives (``extract(..., content_hash=True)``). Read in
    the core with the GIL released.

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
