"""``thermrs extract`` on many recordings: the campaign's rendering (parse and render only;
the work is :func:`thermrs.campaign`)."""

from __future__ import annotations

import glob
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

from thermrs.cli.common import input_file, out_option, rule_option, where_option

if TYPE_CHECKING:
    import polars as pl
    from rich.console import Console

    from thermrs.campaigns import CampaignResult

__all__ = ["SHOWN", "campaign_command", "extract_campaign", "is_campaign", "rows_to_show"]


def is_campaign(
    recordings: tuple[str, ...], out: Path, scheduler: str | None, workers: int | None
) -> bool:
    """Whether the arguments ask for a campaign: several recordings, a glob pattern, a folder
    of recordings with ``-o`` not a ``.parquet`` file, or a Dask option."""
    if len(recordings) > 1 or scheduler is not None or workers is not None:
        return True
    r = recordings[0]
    if not Path(r).exists() and glob.has_magic(r):
        return True
    return Path(r).is_dir() and not out.name.endswith(".parquet")


def extract_campaign(
    recordings: tuple[str, ...],
    rig_path: Path,
    out: Path,
    *,
    scheduler: str | None,
    workers: int | None,
    visit_tolerance_deg: float,
    quiet: bool,
) -> None:
    """Run the campaign with one progress bar over its recordings, print the dashboard's
    address and a summary; exit 3 if a recording lost data, 2 if one could not be read.
    Interrupted (Ctrl-C): exit 130 with one line, how many of the recordings are in the
    dataset and that the same command resumes."""
    import polars as pl
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    from thermrs.campaigns import campaign
    from thermrs.campaigns.engine import CampaignInterrupted
    from thermrs.cli.common import EXIT_BAD_INPUT, EXIT_DATA_LOSS, console

    err = console(stderr=True)

    def on_cluster(link: str | None) -> None:
        if link and not quiet:
            err.print(f"thermrs: Dask dashboard: {link}")

    with Progress(
        TextColumn("[bold]campaign[/bold]"),
        BarColumn(),
        MofNCompleteColumn(),
        TextColumn("{task.fields[last]}"),
        TimeElapsedColumn(),
        console=err,
        disable=quiet or not err.is_terminal,
        transient=True,
    ) as bar:
        task = bar.add_task("campaign", total=None, last="")

        def on_progress(done: int, total: int, path: str) -> None:
            bar.update(task, completed=done, total=total, last=Path(path).name if path else "")

        try:
            res = campaign(
                list(recordings),
                out,
                rig=rig_path,
                scheduler=scheduler,
                workers=workers,
                visit_tolerance_deg=visit_tolerance_deg,
                progress=on_progress,
                on_cluster=on_cluster,
            )
        except CampaignInterrupted as e:
            # The one line of the interruption (thermrs.cli.app): how far, and how to go on.
            raise KeyboardInterrupt(f"{e}; run the same command again to resume") from None
    cat = res.catalog
    if not quiet:
        _print_catalog(err, res, out)
    # The same bytes under two names: catalogued as two recordings; a rule that holds one
    # out against the other would compare a run with itself.
    hashed = cat.filter(pl.col("content_hash").is_not_null())
    twins = hashed.filter(pl.col("content_hash").is_duplicated()).group_by(
        "content_hash", maintain_order=True
    )
    for _, same in twins:
        click.echo(
            f"thermrs: warning: {' and '.join(sorted(same['path'].to_list()))} are the same "
            "recording (identical content): a rule that holds one out against the other "
            "compares a run with itself",
            err=True,
        )
    for row in cat.filter(cat["losses"] > 0).iter_rows(named=True):
        click.echo(
            f"thermrs: data loss: {row['path']}: {row['losses']} damaged part(s), "
            f"{row['lost_bytes']:,} bytes (see the catalog's loss_detail)",
            err=True,
        )
    for path, why in res.failed:
        # The reason names the file already where it came from a reader.
        said = why if str(path) in why else f"{path}: {why}"
        click.echo(f"thermrs: {said}", err=True)
    if res.failed:
        sys.exit(EXIT_BAD_INPUT)
    if res.data_loss:
        sys.exit(EXIT_DATA_LOSS)


def _print_catalog(err: Console, res: CampaignResult, out: Path) -> None:
    """What the campaign did, and its catalog: the recordings that lost data first, then
    this campaign's, at most :data:`SHOWN`."""
    from thermrs.cli.common import table

    err.print(
        f"{len(res.extracted)} recordings extracted, {len(res.unchanged)} unchanged "
        f"(not extracted again), {len(res.failed)} failed, in {res.seconds:.1f} s"
    )
    cat = res.catalog
    shown = rows_to_show(cat, set(res.extracted))  # resolved paths, as the catalog's
    t = table(
        f"Catalog ({out / 'catalog.parquet'})",
        [("recording", "left"), ("runs", "right"), ("frames", "right"), ("losses", "right")],
    )
    for row in shown.iter_rows(named=True):
        t.add_row(row["recording"], str(row["runs"]), f"{row['frames']:,}", str(row["losses"]))
    if cat.height > shown.height:
        t.caption = (
            f"{shown.height} of {cat.height:,} recordings shown (those that lost data "
            f"first, then this campaign's); all of them: {out / 'catalog.parquet'}"
        )
    err.print(t)


def _list_values(ds: Any, query: str | None) -> None:
    """Every value each ``--where`` key takes over the runs ``query`` selects."""
    from thermrs.campaigns.select import campaign_runs, queryable_values

    vals = queryable_values(campaign_runs(ds, query))
    for key, v in vals.items():
        click.echo(f"{key}: {', '.join(v) if v else '(none)'}")


#: Catalog rows the summary of ``thermrs extract`` prints at most (a campaign may hold
#: thousands of recordings; the catalog file has them all).
SHOWN = 20


def rows_to_show(cat: pl.DataFrame, now: set[str], *, limit: int = SHOWN) -> pl.DataFrame:
    """The catalog rows the campaign's summary prints: every row when they fit in ``limit``;
    else those that lost data first, then those extracted by this campaign (``now``: their
    paths), then the rest, each group by recording, ``limit`` rows in all."""
    import polars as pl

    if cat.height <= limit:
        return cat
    order = cat.with_columns(
        _lost=pl.col("losses") > 0, _now=pl.col("path").is_in(sorted(now))
    ).sort(["_lost", "_now", "recording"], descending=[True, True, False])
    return order.head(limit).drop("_lost", "_now")


@click.command("campaign")
@click.argument("dataset", type=click.Path(exists=True, file_okay=False, path_type=Path))
@click.option(
    "--rig",
    "rig_path",
    type=input_file,
    default=None,
    help="Rig file (TOML, SPEC §3); required but with --list.",
)
@where_option
@rule_option("Also fit on training runs and check on held-out runs by this rule.")
@out_option("Write the campaign page (OUT.md or OUT.html).", required=False)
@click.option(
    "--list",
    "list_values",
    is_flag=True,
    help="List every value each --where key takes in the dataset (the runs' recordings, "
    "names, dates, robots, rigs; speed and duration ranges), and stop.",
)
def campaign_command(
    dataset: Path,
    rig_path: Path | None,
    query: str | None,
    rule: str | None,
    out_path: Path | None,
    list_values: bool,
) -> None:
    """α and drift per run across a campaign dataset (written by `thermrs extract` on many
    recordings), runs chosen by query, with the held-out check of a rule."""
    from thermrs.campaigns import Dataset
    from thermrs.campaigns.summary import alpha_by_run, campaign_summary, holdout_by_rule
    from thermrs.cli.common import console, table, writable
    from thermrs.rig import load_rig

    ds = Dataset(dataset)
    if list_values:
        _list_values(ds, query)
        return
    if rig_path is None:
        raise click.UsageError("give --rig RIG (or --list)")
    writable(out_path, "-o", suffixes=(".md", ".html"))
    rig = load_rig(rig_path)
    per_run = alpha_by_run(ds, rig, query=query)
    folds = holdout_by_rule(ds, rig, rule=rule, query=query) if rule else None
    summary = campaign_summary(per_run, folds=folds)
    out = console()
    t = table(
        "α and drift per run",
        [
            ("recording", "left"),
            ("run", "left"),
            ("date", "left"),
            ("speed (%)", "right"),
            ("speed (°/s)", "right"),
            ("α (10⁻⁶/K)", "right"),
            ("95 %", "left"),
            ("largest drift (µm)", "right"),
        ],
    )
    for r in per_run.iter_rows(named=True):
        t.add_row(
            r["recording"],
            r["run"],
            str(r["date"]),
            "—" if r.get("speed_pct") is None else f"{r['speed_pct']:.0f}",
            "—" if r["speed_deg_s"] is None else f"{r['speed_deg_s']:.0f}",
            f"{r['alpha_per_k'] * 1e6:.2f}",
            f"{r['ci95_low'] * 1e6:.2f} … {r['ci95_high'] * 1e6:.2f}",
            f"{r['drift_um']:.2f}",
        )
    out.print(t)
    out.print(f"Over time: {summary.trend['sentence']}.")
    for o in summary.standouts:
        out.print(f"Stands out: {o['recording']}#{o['run']}: {o['why']}.")
    if folds is not None:
        f = table(
            f"Held out ({rule})",
            [("fold", "left"), ("α (10⁻⁶/K)", "right"), ("held-out RMS (µm)", "right")],
        )
        for r in folds.iter_rows(named=True):
            f.add_row(r["fold"], f"{r['alpha_per_k'] * 1e6:.2f}", f"{r['holdout_rms_um']:.2f}")
        out.print(f)
    if out_path is not None:
        from thermrs.report.campaign_page import write_campaign_page

        click.echo(f"wrote {write_campaign_page(summary, out_path)}", err=True)
