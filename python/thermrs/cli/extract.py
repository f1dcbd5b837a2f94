"""``thermrs extract``: a recording to Parquet tables."""

from __future__ import annotations

import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING

import click

from thermrs.cli.common import (
    EXIT_DATA_LOSS,
    console,
    input_file,
    out_option,
    rig_option,
    table,
    writable,
)
from thermrs.defaults import VISIT_TOLERANCE_DEG

if TYPE_CHECKING:  # pragma: no cover
    from rich.console import Console

    from thermrs.ingest import Extraction
    from thermrs.rig import Rig


@click.command()
@click.argument("recordings", nargs=-1, required=True)
@rig_option
@out_option(
    "Frames Parquet (OUT.parquet, in an existing folder); visits, temperatures and joints "
    "are written beside it. For several recordings (or a glob, or a folder): the dataset "
    "folder, partitioned by recording and run, with catalog.parquet."
)
@click.option(
    "--visit-tolerance-deg",
    type=click.FloatRange(min=0, min_open=True, max=180),
    default=VISIT_TOLERANCE_DEG,
    show_default=True,
    help="Joint tolerance (°) for a spot frame to count as at its camera's pose.",
)
@click.option(
    "--scheduler",
    metavar="ADDRESS",
    default=None,
    help="Dask scheduler to run a campaign on (default: a local cluster of worker processes).",
)
@click.option(
    "--workers",
    type=click.IntRange(min=1),
    default=None,
    help="Worker processes of the local cluster (default: the cores).",
)
@click.option(
    "--quiet", is_flag=True, help="No progress bar or summary (a data loss is still reported)."
)
def extract(
    recordings: tuple[str, ...],
    rig_path: Path,
    out_path: Path,
    visit_tolerance_deg: float,
    scheduler: str | None,
    workers: int | None,
    quiet: bool,
) -> None:
    """Extract a recording into Parquet tables: frames (spot centroids), visits,
    temperatures (thermal ROI maxima and ambient) and joints. Several recordings (paths,
    globs, folders) make a campaign: one dataset, extracted on Dask workers, where a
    recording already extracted (same bytes, rig and thermrs version) is not extracted again.

    Exits 3 (after writing every table) if part of the recording was lost: a file cut short,
    a corrupt chunk. The tables remember it (Parquet metadata): fit, predict and drift on
    them exit 3 too.
    """
    from thermrs.cli.campaign import extract_campaign, is_campaign

    if is_campaign(recordings, out_path, scheduler, workers):
        extract_campaign(
            recordings,
            rig_path,
            out_path,
            scheduler=scheduler,
            workers=workers,
            visit_tolerance_deg=visit_tolerance_deg,
            quiet=quiet,
        )
        return
    recording = (
        Path(recordings[0])  # a bag folder (checked as the extraction opens it)
        if Path(recordings[0]).is_dir()
        else input_file.convert(recordings[0], None, click.get_current_context())
    )
    from thermrs.rig import load_rig

    writable(out_path, "-o", suffixes=(".parquet",))
    r = load_rig(rig_path)
    err = console(stderr=True)
    ex, elapsed = _extract_with_progress(
        recording, r, err, quiet=quiet, visit_tolerance_deg=visit_tolerance_deg
    )
    paths = ex.write(out_path)
    rep = ex.report
    if not quiet:
        _say_extracted(err, ex, elapsed, paths)
    # How the file was read where that is worth saying (nothing lost; not with --quiet).
    if not quiet:
        for note in rep.notes:
            click.echo(f"thermrs: note: {recording}: {note}", err=True)
    # The loss is reported even with --quiet: exit 3 never goes unexplained.
    for loss in rep.losses:
        click.echo(f"thermrs: data loss: {recording}: {loss['detail']}", err=True)
    if rep.data_loss:
        sys.exit(EXIT_DATA_LOSS)


def _extract_with_progress(
    recording: Path, r: Rig, err: Console, *, quiet: bool, visit_tolerance_deg: float
) -> tuple[Extraction, float]:
    """Extract ``recording`` under a progress bar (on a terminal only); the extraction and
    the seconds it took."""
    from rich.progress import (
        BarColumn,
        DownloadColumn,
        Progress,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )

    from thermrs.ingest import extract as run_extract

    with Progress(
        TextColumn("[bold]extract[/bold]"),
        BarColumn(),
        DownloadColumn(),
        TextColumn("{task.fields[fps]}"),
        TimeElapsedColumn(),
        TimeRemainingColumn(),
        console=err,
        disable=quiet or not err.is_terminal,  # a bar only where it can redraw
        transient=True,
    ) as bar:
        task = bar.add_task("extract", total=None, fps="")
        t0 = time.perf_counter()

        def on_progress(done: int, total: int, frames: int) -> None:
            dt = max(time.perf_counter() - t0, 1e-9)
            bar.update(task, completed=done, total=total, fps=f"{frames / dt:,.0f} frames/s")

        ex = run_extract(
            recording, r, progress=on_progress, visit_tolerance_deg=visit_tolerance_deg
        )
        elapsed = time.perf_counter() - t0
    return ex, elapsed


def _say_extracted(err: Console, ex: Extraction, elapsed: float, paths: dict[str, Path]) -> None:
    """The summary: counts and speed, frames by status, skipped messages, what was written."""
    rep = ex.report
    n = ex.frames.height
    err.print(
        f"{n:,} frames in {elapsed:.2f} s ({n / max(elapsed, 1e-9):,.0f} frames/s), "
        f"{ex.visits.height} visits, "
        f"{ex.temperatures.height:,} temperature rows, {ex.joints.height:,} joint states"
    )
    t = table("Frames by status", [("status", "left"), ("frames", "right")])
    for k, v in rep.frames_by_status.items():
        t.add_row(k, f"{v:,}")
    err.print(t)
    if rep.skipped:
        s = table("Skipped messages", [("topic: reason (first seen)", "left"), ("count", "right")])
        for k, v in rep.skipped.items():
            s.add_row(rep.skipped_examples.get(k, k), f"{v:,}")
        err.print(s)
    if rep.recovered_messages:
        err.print(f"recovered {rep.recovered_messages} complete messages from the cut chunk")
    for name, p in paths.items():
        err.print(f"wrote {name}: {p}")
