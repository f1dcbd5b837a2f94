"""``thermrs report``: the report a person reads, written — every number computed by
:func:`thermrs.analyses.report_data.report_data` from the results the commands render, then
rendered by :func:`thermrs.report.write_document` (:func:`write_report`) — of runs read from
files (:mod:`thermrs.analyses.report_runs`) or of a campaign's runs (:func:`report`), read from
the dataset: one :class:`~thermrs.report.data.RunInput` per run, as
:func:`thermrs.analyses.report_runs.load_runs` makes from a recording (the run table, the
temperatures, joint states and frames of the run's span), named ``<recording>#<run>``
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
    import os

    from thermrs.diagnose.result import Diagnosis
    from thermrs.report import Written
    from thermrs.report.data import RunInput, Step

__all__ = ["campaign_report_runs", "load_campaign_runs", "report", "write_report"]


def write_report(
    out: str | Path,
    *,
    runs: Sequence[RunInput],
    rig: Rig | str | os.PathLike[str],
    train: Sequence[str] | None = None,
    diagnosis: Diagnosis | None = None,
    exclude: Sequence[str] = (),
    title: str | None = None,
    intro: str | None = None,
    markdown: bool = True,
    pdf: bool = False,
    paper_reference: bool = False,
    step: Step | None = None,
    baselines: bool = False,
) -> Written:
    """Write the report of ``runs``: every number computed
    (:func:`thermrs.analyses.report_data.report_data`), then the document rendered and
    written (:func:`thermrs.report.write_document`).

    Parameters
    ----------
    out
        The HTML file. The Markdown twin is written beside it (``OUT.md``, figures in
        ``OUT_files/``), and with ``pdf`` the PDF (``OUT.pdf``).
    runs
        The runs (:func:`thermrs.analyses.report_runs.load_runs`), in the order shown.
    rig
        The rig they were recorded on.
    train
        Runs α is fitted on (default: the first); the others are held out, predicted and
        diagnosed.
    diagnosis
        A diagnosis already made (default: made here when runs are held out).
    exclude
        Effects the diagnosis may not name (``thermrs diagnose --exclude``); the page says
        which were excluded.
    title
        The report's title.
    intro
        A paragraph placed first in the summary (e.g. what a demo simulated).
    markdown
        Also write the Markdown twin.
    pdf
        Also print the HTML to PDF with headless Chromium.
    paper_reference
        Show the paper's printed Table 4 beside the runs' (for the paper's runs).
    step
        Called with a short description before each stage.
    baselines
        Also show regressions of the drift on the temperatures beside the physical models.

    Returns
    -------
    Written
        The files written.

    Raises
    ------
    InputError
        No runs, a training run that is not given, two runs of one name, a diagnosis of other
        runs or exclusions, or (``pdf``) no Chromium to print with.

    Examples
    --------
    >>> from thermrs.analyses.report_runs import load_runs
    >>> rig = thermrs.load_rig()  # doctest: +SKIP
    >>> write_report("report.html", runs=load_runs("rec.mcap", rig), rig=rig)  # doctest: +SKIP
    """
    from thermrs.analyses.report_data import report_data
    from thermrs.errors import InputError
    from thermrs.report import find_chromium, write_document
    from thermrs.rig import as_rig

    r = as_rig(rig)
    if pdf and find_chromium() is None:
        raise InputError("--pdf needs Chromium (`chromium` on PATH, or THERMRS_CHROMIUM)")
    data = report_data(
        runs,
        r,
        train=train,
        diagnosis=diagnosis,
        exclude=exclude,
        title=title,
        paper_reference=paper_reference,
        step=step,
        baselines=baselines,
    )
    return write_document(data, out, intro=intro, markdown=markdown, pdf=pdf, step=step)


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
        The HTML file (the Markdown twin beside it, see :func:`write_report`).
    runs
        The runs shown, by name (default: every run chosen).
    train
        The runs α is fitted on, by name (default: the first run); the others are held out,
        predicted and diagnosed.
    **options
        :func:`write_report`'s keywords (``title``, ``markdown``, ``pdf``,
        ``step``, …).

    Returns
    -------
    Written
        What was written (:func:`write_report`).

    Raises
    ------
    InputError
        Not a dataset; a bad query or one matching no run; a name naming no run.

    Examples
    --------
    >>> thermrs.analyses.report("campaign/", rig, "november.html",
    ...                          where="date>=2026-11-01", train=["r1#run1"])  # doctest: +SKIP
    """
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
    from thermrs.analyses.report_runs import run_input
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
    reports = _extract_reports(ds, recs)
    frames = scan("frames", "recording", "t_ns", "status")
    out = []
    for r, t in zip(runs.iter_rows(named=True), tables, strict=True):
        rec = pl.col("recording") == r["recording"]
        out.append(
            run_input(
                t,
                temperatures=temps.filter(rec).drop("recording", "run"),
                joints=joints.filter(rec),
                frames=frames.filter(rec),
                window_ns=(int(r["start_ns"]), int(r["end_ns"])),
                source=f"{ds.root}: {r['recording']}",
                recording=str(r["recording"]),
                extract_report=reports.get(str(r["recording"])),
                data_loss=bool(r["losses"]),
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
