"""A recording's tables written into a dataset's staging folder, where the commit that makes
them part of the dataset renames them into place.

Whoever extracted a recording writes its partitions: the worker, where it sees the dataset's
folder (the client leaves a token file in the staging folder; a worker that finds it writes
there, so that only the catalog row travels back), else the client from the Arrow tables the
worker returned (a cluster without shared storage). Staged folders are invisible to readers
until :meth:`thermrs.campaigns.dataset.Dataset.commit` renames them; a job that ran twice (its
worker died) leaves an orphan that the campaign removes at its end.
"""

from __future__ import annotations

import shutil
import urllib.parse
import uuid
from collections.abc import Mapping
from pathlib import Path

import polars as pl

__all__ = ["NULL_PARTITION", "enc", "new_token", "reachable", "write_stage"]

#: Hive's name of the partition of null values (polars reads it back as null).
NULL_PARTITION = "__HIVE_DEFAULT_PARTITION__"


def enc(value: str | None) -> str:
    """A partition value as a folder name (percent-encoded; ``None``: the null partition)."""
    return NULL_PARTITION if value is None else urllib.parse.quote(value, safe="")


def new_token(stage_root: Path) -> str:
    """Create ``stage_root`` and a token file in it; its name (see :func:`reachable`)."""
    stage_root.mkdir(parents=True, exist_ok=True)
    token = f"campaign-{uuid.uuid4().hex}"
    (stage_root / token).touch()
    return token


def reachable(stage_root: str, token: str) -> bool:
    """Whether this process sees the staging folder the client made (its token file)."""
    return bool(token) and (Path(stage_root) / token).is_file()


def write_stage(
    stage_root: Path, rid: str, tables: Mapping[str, pl.DataFrame], meta: dict[str, str]
) -> Path:
    """Write a recording's tables, each split by ``run`` into
    ``<stage>/<table>/run=<run>/part-0.parquet`` (without the column; an empty table as one
    empty file, so that its columns are known), in a new folder under ``stage_root``; that
    folder. Nothing is left behind on failure.

    Raises
    ------
    OSError
        A write failed.
    """
    stage = stage_root / f"{rid}.{uuid.uuid4().hex}"
    try:
        for name, df in tables.items():
            groups = (
                [(None, df)]
                if df.height == 0
                else [(k[0], g) for k, g in df.group_by("run", maintain_order=True)]
            )
            for run, g in groups:
                d = stage / name / f"run={enc(run)}"
                d.mkdir(parents=True)
                g.drop("run").write_parquet(d / "part-0.parquet", metadata=meta)
    except BaseException:
        shutil.rmtree(stage, ignore_errors=True)
        raise
    return stage
