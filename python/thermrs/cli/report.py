"""``thermrs report``: parse, call :func:`thermrs.analyses.report.write_report` (or the demo,
:func:`thermrs.analyses.demo.run_demo`), show progress and what was written. The report's own
modules (and matplotlib) load only when it runs."""

from __future__ import annotations

import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING

import click
from rich.console import Console

from thermrs.cli.common import (
    CAMPAIGN_NAMES_HELP,
    EXIT_DATA_LOSS,
    Stage,
    campaign_options,
    exclude_option,
    no_campaign,
    out_option,
    stages,
    writable,
)
from thermrs.errors import InputError

if TYPE_CHECKING:  # pragma: no cover
    from thermrs.report import Written
    from thermrs.report.data import RunInput
    from thermrs.rig import Rig

__all__ = ["report"]


@click.command()
@click.option(
    "--demo",
    is_flag=True,
    help="Simulate the paper's three 15-hour runs from the embedded rig and the packaged demo "
    "scenario, and report on them (needs no other option).",
)
@click.option(
    "--rig",
    "rig_path",
    type=click.Path(path_type=Path),
    default=None,
    help="Rig file (required without --demo).",
)
@click.option(
    "--run",
    "runs",
    multiple=True,
    type=click.Path(path_type=Path),
    help="Runs: recordings (MCAP) or tables written by `thermrs extract`; FILE#RUN takes one "
    "run of a file (FILE alone: each of its runs, split as every command splits them)."
    + CAMPAIGN_NAMES_HELP,
)
@click.option(
    "--train",
    "train",
    multiple=True,
    type=click.Path(path_type=Path),
    help="Runs α is fitted on (default: the first --run); the others are held out, predicted "
    "and diagnosed. A --train run not given as --run is added." + CAMPAIGN_NAMES_HELP,
)
@out_option(
    "HTML file to write [default: thermrs-report.html, or thermrs-demo-report.html with "
    "--demo]; the Markdown twin OUT.md and its figures OUT_files/ go beside it.",
    required=False,
)
@click.option("--pdf", is_flag=True, help="Also print the report to OUT.pdf (headless Chromium).")
@click.option("--no-markdown", is_flag=True, help="Write only the HTML.")
@click.option("--title", default=None, help="The report's title.")
@click.option(
    "--workdir",
    type=click.Path(path_type=Path),
    default=None,
    help="--demo: keep the simulated recording and its truth here (default: a temporary folder).",
)
@click.option(
    "--diagnosis",
    "diagnosis_path",
    type=click.Path(path_type=Path),
    default=None,
    help="A `thermrs diagnose --json` file of the same runs: the report shows it (and designs "
    "from it) instead of diagnosing the runs again, so its numbers are the file's.",
)
@exclude_option(
    "Effects the report's diagnosis may not name (SPEC §6 names; --exclude A B or repeats), as "
    "`thermrs diagnose --exclude`; the page says which were excluded. With --diagnosis: the "
    "ones that diagnosis excluded."
)
@click.option(
    "--baselines",
    is_flag=True,
    help="Add regressions of the drift on the temperatures, fitted on the training runs and "
    "scored on the held-out runs beside the physical models, with a figure (a subsection of "
    "the diagnosis).",
)
@click.option("--quiet", is_flag=True, help="No progress.")
@click.option("--verbose", is_flag=True, help="Print the seconds each stage took (stderr).")
@campaign_options()
def report(
    demo: bool,
    rig_path: Path | None,
    runs: tuple[Path, ...],
    train: tuple[Path, ...],
    out_path: Path | None,
    pdf: bool,
    no_markdown: bool,
    title: str | None,
    workdir: Path | None,
    diagnosis_path: Path | None,
    exclude: tuple[str, ...],
    baselines: bool,
    quiet: bool,
    verbose: bool,
    campaign_path: Path | None,
    query: str | None,
) -> None:
    """Write the report a person reads: one self-contained HTML file (figures inline, opens
    offline) and a Markdown twin, for one run or a campaign, from recordings or extracted
    tables: summary, rig, drift and temperatures per run, heating curves, Table 4/6/7-style
    tables, prediction against measurement, ISO 9283-style repeatability, the diagnosis and
    what extraction skipped.

    `thermrs report --demo` simulates the paper's runs and reports on them; `thermrs report
    --campaign DATASET [--where QUERY]` reports on runs of a campaign dataset.

    Exits 3 (after writing the report) if part of a recording was lost.
    """
    err = Console(stderr=True, highlight=False)
    _check_options(demo, rig_path, runs, train, campaign_path, query)
    if demo and diagnosis_path is not None:
        raise click.UsageError("--demo takes no --diagnosis (it diagnoses the runs it simulates)")
    if demo and exclude:
        raise click.UsageError("--demo takes no --exclude (its report is written as it is)")
    if demo and baselines:
        raise click.UsageError("--baselines needs runs: the demo's report is written as it is")
    given = None
    if diagnosis_path is not None:
        from thermrs.diagnose.result import Diagnosis

        given = Diagnosis.read(diagnosis_path)
        if given.unverified:
            click.echo(f"thermrs: warning: {diagnosis_path}: {given.unverified}", err=True)
    out = out_path or Path("thermrs-demo-report.html" if demo else "thermrs-report.html")
    writable(out, "-o")
    t_start = time.perf_counter()
    with stages("report", verbose=verbose, quiet=quiet) as stage:
        loss = False
        if demo:
            from thermrs.analyses.demo import run_demo

            res = run_demo(out, workdir=workdir, pdf=pdf, markdown=not no_markdown, progress=stage)
            written = res.written
        else:
            from thermrs.analyses.report import write_report
            from thermrs.rig import load_rig

            assert rig_path is not None
            rig = load_rig(rig_path)
            if campaign_path is not None:  # the runs of a campaign dataset, by query and name
                stage(f"reading {campaign_path}")
                loaded, train_names = _campaign_runs(campaign_path, rig, query, runs, train)
                loss = any(r.data_loss for r in loaded)
            else:
                loaded, train_names, loss = _file_runs(rig, runs, train, stage)
            written = write_report(
                out,
                runs=loaded,
                rig=rig,
                train=train_names or None,
                diagnosis=given,
                exclude=exclude,
                title=title,
                markdown=not no_markdown,
                pdf=pdf,
                step=stage,
                baselines=baselines,
            )
    if not quiet:
        _say_written(err, written, time.perf_counter() - t_start)
    if loss:
        sys.exit(EXIT_DATA_LOSS)


def _check_options(
    demo: bool,
    rig_path: Path | None,
    runs: tuple[Path, ...],
    train: tuple[Path, ...],
    campaign_path: Path | None,
    query: str | None,
) -> None:
    """The options go together, and every run file given exists (one line, exit 2)."""
    if demo and (runs or train or rig_path is not None or campaign_path is not None):
        raise click.UsageError("--demo takes no --rig, --run or --train (nor --campaign)")
    no_campaign(campaign_path, query)
    if not demo and not runs and not train and campaign_path is None:
        raise click.UsageError("give --run RUN… (and --rig RIG), or --demo, or --campaign DATASET")
    if not demo and rig_path is None:
        raise click.UsageError("give --rig RIG")
    from thermrs.ingest import NOT_A_BAG, is_bag
    from thermrs.runs import split_run_spec

    for p in (*train, *runs) if campaign_path is None else ():
        f = split_run_spec(p)[0]
        if f.is_dir() and not is_bag(f):
            raise InputError(f"{f}: {NOT_A_BAG}")
        if not f.exists():
            raise InputError(f"{f}: no such file")


def _file_runs(
    rig: Rig,
    runs: tuple[Path, ...],
    train: tuple[Path, ...],
    stage: Stage,
) -> tuple[list[RunInput], list[str], bool]:
    """The report's runs from files (:func:`thermrs.analyses.report_runs.read_report_runs`), each
    file's runs told on stderr as every command tells them; the training runs' names; whether
    data was lost."""
    from thermrs.analyses.report_runs import read_report_runs
    from thermrs.cli.common import say

    got = read_report_runs(train, runs, rig, say=say, step=stage)
    if got.train:
        from thermrs.analyses.inputs import distinct_runs

        distinct_runs(
            [r.table for r in got.runs if r.name in got.train],
            [r.table for r in got.runs if r.name not in got.train],
            "--run",
        )
    return got.runs, got.train, got.data_loss


def _say_written(err: Console, written: Written, elapsed: float) -> None:
    """What was written, where, and how long it took."""
    err.print(
        f"wrote {written.html} ({written.html_bytes / 1e3:,.0f} kB, self-contained) in "
        f"{elapsed:.1f} s"
    )
    if written.markdown is not None:
        fig_dir = next(iter(written.figures.values())).parent if written.figures else None
        err.print(
            f"wrote {written.markdown}"
            + (f" and {len(written.figures)} figures in {fig_dir}/" if fig_dir else "")
        )
    if written.pdf is not None:
        err.print(f"wrote {written.pdf}")


def _campaign_runs(
    campaign_path: Path,
    rig: Rig,
    query: str | None,
    runs: tuple[Path, ...],
    train: tuple[Path, ...],
) -> tuple[list[RunInput], list[str]]:
    """The report's runs from a campaign dataset (:mod:`thermrs.analyses.report`), listed on
    stderr, and the training runs' names."""
    from thermrs.analyses.report import campaign_report_runs

    loaded, train_names = campaign_report_runs(
        campaign_path, rig, where=query, runs=[str(p) for p in runs], train=[str(p) for p in train]
    )
    click.echo(
        f"thermrs: {campaign_path}: {len(loaded)} run(s): " + ", ".join(r.name for r in loaded),
        err=True,
    )
    return loaded, train_names
