"""A campaign dataset on disk: Parquet tables partitioned by recording and run, and a catalog.

Layout under the dataset folder ``OUT``::

    OUT/frames/recording=<id>/run=<run>/part-0.parquet     (also visits, temperatures,
    OUT/runs/recording=<id>/run=<run>/part-0.parquet        joints; hive style, values
    OUT/_catalog/<id>.parquet                               percent-encoded; rows no run
    OUT/catalog.parquet                                     covers: run=__HIVE_DEFAULT_PARTITION__)

A recording is committed in three steps: its tables are written into a staging folder
(``OUT/.staging``), each table's folder is renamed into place, and then its catalog fragment
(``_catalog/<id>.parquet``, one row) is written atomically. The fragment is the commit: a
recording without one is not part of the dataset (readers filter on the catalog, and the next
campaign removes what an interruption left behind). ``catalog.parquet`` is the fragments in
one table, rewritten atomically at the end of each campaign, for other tools.

Every data file carries the recording's losses in its Parquet metadata (``LOSS_KEY``), as the
single-recording tables of ``thermrs extract`` do.
"""

from __future__ import annotations

import shutil
from pathlib import Path
from typing import Any

import polars as pl

from thermrs.campaigns.staging import NULL_PARTITION, write_stage
from thermrs.campaigns.staging import enc as _enc
from thermrs.campaigns.task import RUN_STATS_SCHEMA, TABLES
from thermrs.errors import InputError
from thermrs.ingest import LOSS_KEY, write_parquet_atomic

__all__ = ["CATALOG_SCHEMA", "NULL_PARTITION", "Dataset"]

CATALOG_SCHEMA: dict[str, Any] = {
    "recording": pl.String,
    "path": pl.String,
    "content_hash": pl.String,
    "size_bytes": pl.Int64,
    "mtime_ns": pl.Int64,
    "runs": pl.Int64,
    "frames": pl.Int64,
    "visits": pl.Int64,
    "start_ns": pl.Int64,
    "end_ns": pl.Int64,
    "duration_s": pl.Float64,
    "rig": pl.String,
    "rig_hash": pl.String,
    "robot": pl.String,
    "losses": pl.Int64,
    "lost_bytes": pl.Int64,
    "loss_detail": pl.String,
    "crc_failures": pl.Int64,
    "thermrs_version": pl.String,
    "options": pl.String,
    "extracted_at": pl.String,
    #: The extraction's whole report as JSON (:class:`thermrs.ingest.ExtractReport`: messages
    #: read per topic, skipped and why, losses); null in datasets written before it was kept.
    "report": pl.String,
}


def _first_unreadable(parts: list[Path], err: Exception) -> tuple[str, str]:
    """The first fragment polars cannot read, and why (one line); the scan's own error when
    each reads alone."""
    for p in parts:
        try:
            pl.read_parquet_schema(p)
        except (pl.exceptions.PolarsError, OSError) as e:
            return p.name, str(e).splitlines()[0]
    return "*.parquet", str(err).splitlines()[0]


class Dataset:
    """A campaign dataset folder.

    Parameters
    ----------
    root
        The dataset folder: one ``thermrs extract REC… -o DATASET`` wrote.
    create
        Create it (and its catalog) if missing, to write into; its parent must exist. Without
        it nothing is created: reading a folder that does not exist is an error.

    Raises
    ------
    InputError
        ``root`` is a file; without ``create``: it does not exist or holds no catalog; with
        ``create``: its parent folder does not exist.
    """

    def __init__(self, root: str | Path, *, create: bool = False) -> None:
        root = Path(root)
        if root.exists() and not root.is_dir():
            raise InputError(f"dataset {root}: is a file, expected a folder")
        if not create:
            if not root.exists():
                raise InputError(f"dataset {root}: no such folder")
            if not (root / "_catalog").is_dir():
                raise InputError(
                    f"dataset {root}: not a campaign dataset (no _catalog/; write one with "
                    "`thermrs extract REC… -o DATASET`)"
                )
            self.root = root
            return
        if not root.parent.is_dir():
            raise InputError(
                f"dataset {root}: folder {root.parent} does not exist (create it first)"
            )
        try:
            (root / "_catalog").mkdir(parents=True, exist_ok=True)
        except OSError as e:
            raise InputError(f"dataset {root}: {e.strerror or e}") from None
        self.root = root

    @classmethod
    def open(cls, root: str | Path) -> Dataset:
        """A dataset that ``thermrs extract`` wrote, for reading (nothing is created): the
        same as ``Dataset(root)``.

        Raises
        ------
        InputError
            ``root`` does not exist, is not a folder, or holds no catalog.
        """
        return cls(root)

    # --- reading ----------------------------------------------------------------------------
    def catalog(self) -> pl.DataFrame:
        """One row per committed recording (columns :data:`CATALOG_SCHEMA`), by id."""
        parts = sorted((self.root / "_catalog").glob("*.parquet"))
        if not parts:
            return pl.DataFrame(schema=CATALOG_SCHEMA)
        # One scan over every fragment, read by polars' own readers (not a Python loop of
        # `read_parquet`: 6.4x less time on 2,000 fragments, BENCHMARKS.md), against the
        # catalog's schema: a fragment written before a column existed gets nulls there.
        try:
            return (
                pl.scan_parquet(
                    parts,
                    schema=CATALOG_SCHEMA,
                    missing_columns="insert",
                    extra_columns="ignore",
                    cast_options=pl.ScanCastOptions(integer_cast="upcast"),
                )
                .sort("recording")
                .collect()
            )
        except pl.exceptions.PolarsError as e:
            bad, why = _first_unreadable(parts, e)
            raise InputError(
                f"dataset {self.root}: catalog fragment _catalog/{bad} is unreadable: {why}"
            ) from None

    def scan(self, table: str) -> pl.LazyFrame:
        """A committed table of every recording, read lazily, with ``recording`` and ``run``
        columns from the partitions.

        Raises
        ------
        InputError
            ``table`` is not one of :data:`thermrs.campaigns.task.TABLES`.
        """
        if table not in TABLES:
            raise InputError(f"dataset table {table!r}: not one of {', '.join(TABLES)}")
        committed = self.catalog()["recording"].to_list()
        files = [
            f
            for rid in committed
            for f in (self.root / table / f"recording={_enc(rid)}").rglob("*.parquet")
        ]
        if not files:
            return pl.LazyFrame(schema={"recording": pl.String, "run": pl.String})
        # The runs table's columns are fixed: a recording extracted before a column existed
        # reads it as null, wherever it comes in the list.
        schema = {k: v for k, v in RUN_STATS_SCHEMA.items() if k != "run"}
        return pl.scan_parquet(
            files,
            schema=schema if table == "runs" else None,
            hive_partitioning=True,
            hive_schema={"recording": pl.String, "run": pl.String},
            missing_columns="insert",
        )

    # --- writing ----------------------------------------------------------------------------
    def clean(self) -> None:
        """Remove what an interrupted campaign left: staging folders, and partitions of
        recordings that have no catalog fragment (never committed)."""
        shutil.rmtree(self.root / ".staging", ignore_errors=True)
        committed = {_enc(r) for r in self.catalog()["recording"].to_list()}
        for table in TABLES:
            d = self.root / table
            if not d.is_dir():
                continue
            for part in d.iterdir():
                if part.name.startswith("recording=") and part.name[10:] not in committed:
                    shutil.rmtree(part, ignore_errors=True)

    def uncommit(self, rid: str) -> None:
        """Take a recording out of the dataset (its fragment first, then its partitions)."""
        (self.root / "_catalog" / f"{rid}.parquet").unlink(missing_ok=True)
        for table in TABLES:
            shutil.rmtree(self.root / table / f"recording={_enc(rid)}", ignore_errors=True)

    def commit(
        self,
        row: dict[str, Any],
        tables: dict[str, Any] | None = None,
        *,
        staged: str | Path | None = None,
    ) -> None:
        """Write one recording's tables and catalog row (see the module docs for the steps).

        Parameters
        ----------
        row
            Its catalog row (:data:`CATALOG_SCHEMA`).
        tables
            Table name → Arrow table with a ``run`` column (null: no run covers the row);
            written into the staging folder here.
        staged
            Or: the folder a worker already wrote them into
            (:func:`thermrs.campaigns.staging.write_stage`).
        """
        rid = str(row["recording"])
        meta = {LOSS_KEY: str(row.get("loss_detail") or "[]")}
        stage: Path | None = Path(staged) if staged is not None else None
        try:
            if stage is None:
                frames = {k: pl.from_arrow(v) for k, v in (tables or {}).items()}
                stage = write_stage(self.root / ".staging", rid, frames, meta)  # type: ignore[arg-type]
            self.uncommit(rid)
            for name in sorted(p.name for p in stage.iterdir()):
                dest = self.root / name / f"recording={_enc(rid)}"
                dest.parent.mkdir(exist_ok=True)
                (stage / name).rename(dest)
            cat = pl.DataFrame({k: [row.get(k)] for k in CATALOG_SCHEMA}, schema=CATALOG_SCHEMA)
            write_parquet_atomic(cat, self.root / "_catalog" / f"{rid}.parquet")
        except OSError as e:
            raise InputError(
                f"dataset {self.root}: cannot write {rid}: {e.strerror or e}"
            ) from None
        finally:
            if stage is not None:
                shutil.rmtree(stage, ignore_errors=True)

    def open_staging(self) -> tuple[Path, str]:
        """The staging folder (absolute) and a new token for workers to find it by."""
        from thermrs.campaigns.staging import new_token

        root = (self.root / ".staging").resolve()
        return root, new_token(root)

    def close_staging(self) -> None:
        """Remove the staging folder: what is left in it was never committed (a job that ran
        twice because its worker died, an interrupted write)."""
        shutil.rmtree(self.root / ".staging", ignore_errors=True)

    def touch(self, rid: str, updates: dict[str, Any]) -> None:
        """Update a committed recording's catalog row (e.g. the path and modification time of a
        file renamed or touched but holding the same bytes)."""
        path = self.root / "_catalog" / f"{rid}.parquet"
        df = pl.read_parquet(path).with_columns(
            [pl.lit(v, CATALOG_SCHEMA[k]).alias(k) for k, v in updates.items()]
        )
        write_parquet_atomic(df, path)

    def consolidate(self) -> Path:
        """Write ``catalog.parquet`` (every fragment in one table) atomically; its path."""
        path = self.root / "catalog.parquet"
        write_parquet_atomic(self.catalog(), path)
        return path
