"""The digest a diagnosis keeps of each of its runs (thermrs.identity.run_digest): the same
content digests alike however it was stored and read back (written by polars, read by
pyarrow, in many chunks), and one value changed by the least a float can change does not."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import polars as pl
import pyarrow.parquet as pq  # type: ignore[import-untyped]
from thermrs.identity import run_digest, run_digests


def table() -> pl.DataFrame:
    rng = np.random.default_rng(1)
    n = 500
    return pl.DataFrame(
        {
            "run": ["rec#a"] * n,
            "camera": rng.choice(["A", "B"], n).tolist(),
            "t_ns": 1_750_090_000_763_156_603 + np.arange(n, dtype=np.int64) * 120 * 10**9,
            "u_um": rng.normal(size=n),
            "link2_c": [None if i % 50 == 0 else 23.0 + i / 100 for i in range(n)],
        }
    )


def test_the_same_content_digests_alike_however_stored(tmp_path: Path) -> None:
    t = table()
    t.write_parquet(tmp_path / "t.parquet", row_group_size=37)
    back = pl.from_arrow(pq.read_table(tmp_path / "t.parquet"))
    assert isinstance(back, pl.DataFrame) and back.n_chunks() > 1
    assert run_digest(back) == run_digest(t)
    assert run_digests([t]) == {"rec#a": run_digest(t)}


def test_one_ulp_or_one_null_changes_it() -> None:
    t = table()
    u = t["u_um"].to_numpy().copy()
    u[123] = np.nextafter(u[123], np.inf)
    assert run_digest(t.with_columns(u_um=pl.Series(u))) != run_digest(t)
    assert run_digest(t.with_columns(pl.col("link2_c").fill_null(0.0))) != run_digest(t)


def test_a_run_renamed_digests_alike() -> None:
    # A campaign names a run by its recording's id, a file by its stem: the same content.
    t = table()
    renamed = t.with_columns(pl.lit("r1-5adfc9d829a3#a").alias("run"))
    assert run_digest(t) == run_digest(renamed)
