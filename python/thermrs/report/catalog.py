"""The report's runs read from a campaign dataset (``thermrs report --campaign DATASET``): one
:class:`~thermrs.report.data.RunInput` per run, as :func:`thermrs.report.data.load_runs` makes
from a recording (the run table, the temperatures, joint states and frames of the run's span),
named ``<recording>#<run>`` (:mod:`thermrs.campaigns.inputs`)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import polars as pl

from thermrs.report.data import RunInput
from thermrs.rig import Rig

__all__ = ["load_campaign_runs"]


def load_campaign_runs(
    dataset: Any, rig: Rig, *, where: str | None = None, names: Sequence[str] = ()
) -> list[RunInput]:
    """The runs ``where`` selects (or the ``names`` among them), in time order (or as named).

    Parameters
    ----------
    dataset
        A :class:`thermrs.campaigns.Dataset` or the folder ``thermrs extract`` wrote.
    rig
        The rig the runs were recorded on.
    where
        The query choosing runs (:func:`thermrs.campaigns.select.parse_query`).
    names
        Runs by name, ``<recording>#<run>`` or ``<recording>`` (each of its runs).

    Raises
    ------
    InputError
        Not a dataset; a bad query or one matching no run; a name naming no run; a run
        without a visit with a spot.
    """
    from thermrs.campaigns.inputs import open_dataset, pick_runs, selected
    from thermrs.campaigns.select import campaign_runs

    ds = open_dataset(dataset)
    runs = campaign_runs(ds, where)
    if names:
        runs = pick_runs(runs, names)
    tables = selected(ds, rig, where=where, names=names).train
    recs = runs["recording"].unique().to_list()

    def scan(table: str, *cols: str) -> pl.DataFrame:
        lf = ds.scan(table).filter(pl.col("recording").is_in(recs))
        return (lf.select(*cols) if cols else lf).collect()

    temps, joints = scan("temperatures"), scan("joints", "recording", "t_ns")
    frames = scan("frames", "recording", "t_ns", "status")
    out = []
    for r, t in zip(runs.iter_rows(named=True), tables, strict=True):

        def cut(df: pl.DataFrame, r: dict[str, Any] = r) -> pl.DataFrame:
            return df.filter(
                (pl.col("recording") == r["recording"])
                & pl.col("t_ns").is_between(r["start_ns"], r["end_ns"])
            )

        counts = cut(frames).group_by("status").len().sort("status").iter_rows()
        out.append(
            RunInput(
                name=str(t["run"][0]),
                table=t,
                source=f"{ds.root}: {r['recording']}",
                temperatures=cut(temps).drop("recording", "run"),
                joints=cut(joints).height,
                frames_by_status={str(k): int(v) for k, v in counts},
                data_loss=bool(r["losses"]),
                recording=str(r["recording"]),
            )
        )
    return out
