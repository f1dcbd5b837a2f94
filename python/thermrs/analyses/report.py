"""``thermrs report --campaign``: the report a person reads, of a campaign's runs, and those runs
read from the dataset: one :class:`~thermrs.report.data.RunInput` per run, as
:func:`thermrs.report.data.load_runs` makes from a recording (the run table, the temperatures,
joint states and frames of the run's span), named ``<recording>#<run>``
(:mod:`thermrs.analyses.inputs`)."""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import polars as pl

from thermrs.analyses.inputs import DatasetLike
from thermrs.ingest import ExtractReport
from thermrs.rig import Rig

if TYPE_CHECKING:
    # The report package is read when a report is made, not when thermrs.analyses is
    # imported: ``thermrs fit`` and the other commands load no report module.
    from thermrs.report import Written
    from thermrs.report.data import RunInput

__all__ = ["campaign_report_runs", "load_campaign_runs", "report"]


def report(
    dataset: DatasetLike,
    rig: Any,
    out: str | Path,
    *,
    where: str | None = None,
    runs: Sequence[str] = (),
    train: Sequence[str] = (),
    **options: Any,
) -> Written:
    """The report a person reads, of a campaign's runs, as ``thermrs report --campaign``
    writes it.

    Parameters
    ----------
    dataset, rig, where
        As :func:`thermrs.analyses.fit.fit`.
    out
        The HTML file (the Markdown twin beside it, see :func:`thermrs.report.write_report`).
    runs
        The runs shown, by name (default: every run chosen).
    train
        The runs α is fitted on, by name (default: the first run); the others are held out,
        predicted and diagnosed.
    **options
        :func:`thermrs.report.write_report`'s keywords (``title``, ``markdown``, ``pdf``,
        ``step``, …).

    Returns
    -------
    Written
        What was written (:func:`thermrs.report.write_report`).

    Raises
    ------
    InputError
        Not a dataset; a bad query or one matching no run; a name naming no run.

    Examples
    --------
    >>> thermrs.analyses.report("campaign/", rig, "november.html",
    ...                          where="date>=2026-11-01", train=["r1#run1"])  # doctest: +SKIP
    """
    from thermrs.report import write_report

    loaded, train_names = campaign_report_runs(dataset, rig, where=where, runs=runs, train=train)
    return write_report(out, runs=loaded, rig=rig, train=train_names or None, **options)


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
    from thermrs.analyses.inputs import open_dataset, pick_runs, selected
    from thermrs.campaigns.select import campaign_runs
    from thermrs.report.data import RunInput

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
    reports = _extract_reports(ds, recs)
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
                extract_report=reports.get(str(r["recording"])),
                data_loss=bool(r["losses"]),
                recording=str(r["recording"]),
            )
        )
    return out


def campaign_report_runs(
    dataset: Any,
    rig: Rig,
    *,
    where: str | None = None,
    runs: Sequence[str] = (),
    train: Sequence[str] = (),
) -> tuple[list[RunInput], list[str]]:
    """The runs of ``thermrs report --campaign``: the ``train`` runs then the ``runs`` named
    (default: every run ``where`` selects, the ``train`` runs first), and the training runs'
    names (empty: the report's default, the first run).

    Raises
    ------
    InputError
        As :func:`load_campaign_runs`.
    """
    from thermrs.analyses.inputs import open_dataset, pick_runs
    from thermrs.campaigns.select import campaign_runs

    ds = open_dataset(dataset)
    train_names: list[str] = []
    if train:
        rows = pick_runs(campaign_runs(ds, where), train, what="--train")
        train_names = [f"{a}#{b}" for a, b in rows.select("recording", "run").iter_rows()]
    if runs:
        names = [*train_names, *runs]
    elif train:
        names = [
            *train_names,
            *campaign_runs(ds, where)
            .select(pl.concat_str("recording", pl.lit("#"), "run"))["recording"]
            .to_list(),
        ]
    else:
        names = []
    return load_campaign_runs(ds, rig, where=where, names=names), train_names


def _extract_reports(ds: Any, recordings: Sequence[str]) -> dict[str, ExtractReport]:
    """Each recording's extraction report as the catalog keeps it (one object per recording,
    shared by its runs; none for datasets written before the catalog kept it)."""
    cat = ds.catalog().filter(pl.col("recording").is_in(list(recordings)))
    return {
        str(rid): ExtractReport(**json.loads(text))
        for rid, text in cat.select("recording", "report").iter_rows()
        if text
    }
