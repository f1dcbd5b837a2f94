"""Outputs written atomically (SPEC §7): to a temporary file beside the target, then renamed
over it; a failure or Ctrl-C leaves the target as it was and no temporary behind. Built on
:func:`thermrs.ingest.atomic_tmp` and :func:`thermrs.ingest.publish` (which also check the
folder and name the path in their errors)."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # pragma: no cover
    import polars as pl

__all__ = ["write_atomic", "write_csv", "write_json", "write_text"]


def write_atomic(path: Path, write: Callable[[Path], object]) -> None:
    """Call ``write(tmp)`` and publish ``tmp`` as ``path``; remove ``tmp`` on any failure."""
    from thermrs.ingest import atomic_tmp, publish

    tmp = atomic_tmp(path)
    try:
        write(tmp)
        publish(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def write_text(path: Path, text: str) -> None:
    """``text`` (UTF-8) to ``path``, atomically."""
    write_atomic(path, lambda tmp: tmp.write_text(text, encoding="utf-8"))


def write_json(path: Path, doc: object) -> None:
    """``doc`` as indented JSON to ``path``, atomically."""
    write_text(path, json.dumps(doc, indent=2))


def write_csv(path: Path, df: pl.DataFrame) -> None:
    """``df`` as CSV to ``path``, atomically."""
    write_atomic(path, df.write_csv)
