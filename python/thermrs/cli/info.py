"""``thermrs info REC… | 'GLOB' | FOLDER``: what recordings hold, from their summaries and
indexes (no message is decoded): topics, message counts, duration, runs (markers or idle
gaps), the cameras and ROIs the rig maps, losses. Recordings are named as for ``thermrs
extract`` (:func:`thermrs.campaigns.sources.expand`). Parses and renders;
:mod:`thermrs.inventory` computes."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import click

from thermrs.cli.common import EXIT_DATA_LOSS, input_file, out, table

__all__ = ["VISIT_RULE", "info"]

#: How ``info`` counts visits, and why it can count otherwise than ``thermrs extract``: it
#: decodes no message, so it sees no joint state and no header stamp.
VISIT_RULE = (
    "a visit is a burst of one camera topic's frames, by log time (no message decoded); "
    "`thermrs extract` counts a visit only where the joints are at the camera's pose, so "
    "a camera's frames taken at another pose make more visits here, and may split runs "
    "that extract keeps whole"
)
#: Without a rig, which topics are cameras.
NO_RIG_RULE = "without --rig every sensor_msgs/msg/Image topic counts as a camera, thermal too"


def _span(ns: float) -> str:
    s = ns / 1e9
    return f"{s / 3600:.2f} h" if s >= 3600 else f"{s / 60:.1f} min" if s >= 60 else f"{s:.1f} s"


@click.command()
@click.argument("recordings", nargs=-1, required=True)
@click.option(
    "--rig",
    "rig_path",
    type=input_file,
    default=None,
    help="Rig file: name each topic's role and list the cameras and ROIs it maps.",
)
@click.option("--json", "as_json", is_flag=True, help="Print JSON instead of tables.")
def info(recordings: tuple[str, ...], rig_path: Path | None, as_json: bool) -> None:
    """What recordings hold, in about a second whatever their size: topics and message
    counts, duration, runs (run markers, else idle gaps), the cameras and ROIs the rig maps,
    and what could not be read. Read from the MCAP summary and indexes; no frame is decoded.
    Recordings: paths, globs and folders (every *.mcap below them), as for extract.

    Visits are bursts of each camera topic's frames by log time: without joint states (not
    decoded) a camera's frame at another pose counts too, so visits and runs can differ from
    extract's; without --rig every Image topic counts as a camera.

    Exits 3 if part of a recording cannot be read (cut short, an index past its end).
    """
    from thermrs.campaigns.sources import expand
    from thermrs.inventory import inventory
    from thermrs.rig import load_rig

    rig = load_rig(rig_path) if rig_path is not None else None
    paths = [s.path for s in expand(recordings, resolve=False)]
    invs = [inventory(p, rig=rig) for p in paths]
    if as_json:
        click.echo(json.dumps([i.to_json() for i in invs], indent=2))
    for inv in invs if not as_json else []:
        t0 = inv.start_ns
        out.print(
            f"[bold]{inv.path}[/bold]: {inv.storage}, {inv.bytes / 1e6:,.1f} MB, "
            f"{inv.messages:,} messages "
            f"over {_span(inv.duration_s * 1e9 if t0 is not None else 0)}, {inv.chunks} chunks "
            f"({', '.join(inv.compression) or 'unchunked'}); "
            + (
                "read from its summary"
                if inv.from_summary
                else "read from its SQLite tables"
                if "sqlite3" in inv.storage and "mcap" not in inv.storage
                else "no summary: walked record by record"
            )
        )
        t = table("Topics", [("topic", "left"), ("schema", "left"), ("messages", "right"),
                             ("rig", "left")])  # fmt: skip
        for row in inv.topics.iter_rows(named=True):
            t.add_row(row["topic"], row["schema"], f"{row['messages']:,}", row["role"])
        out.print(t)
        t = table(
            "Runs (" + ("run markers" if set(inv.runs["source"]) == {"marker"} else "idle gaps")
            + ")",
            [("run", "left"), ("start", "right"), ("length", "right"), ("visits", "right"),
             ("source", "left")],
        )  # fmt: skip
        for row in inv.runs.iter_rows(named=True):
            start = "" if t0 is None else f"+{_span(max(row['start_ns'] - t0, 0))}"
            t.add_row(row["run"], start, _span(row["end_ns"] - row["start_ns"]),
                      str(row["visits"]), row["source"])  # fmt: skip
        out.print(t)
        if inv.cameras is not None:
            t = table("Cameras the rig maps", [("camera", "left"), ("topic", "left"),
                                               ("pose", "left"), ("frames", "right")])  # fmt: skip
            for row in inv.cameras.iter_rows(named=True):
                frames = f"{row['frames']:,}" if row["frames"] else "none in the file"
                t.add_row(row["camera"], row["topic"], row["pose"], frames)
            out.print(t)
        if inv.rois is not None and inv.rois.height:
            t = table(
                f"Thermal ROIs ({inv.thermal_frames or 0:,} thermal frames, "
                f"{inv.ambient_readings or 0:,} ambient readings, "
                f"{inv.joint_states or 0:,} joint states)",
                [("roi", "left"), ("rect (x0, y0, x1, y1)", "left"), ("expands", "left")],
            )
            for row in inv.rois.iter_rows(named=True):
                t.add_row(row["roi"], ", ".join(map(str, row["rect_px"])), row["drives"] or "—")
            out.print(t)
        for note in inv.notes:
            out.print(f"note: {note}", markup=False, soft_wrap=True)
        for loss in inv.losses:
            out.print(f"[bold]loss[/bold]: {loss}")
    if invs and not as_json:
        rule = VISIT_RULE + ("" if rig is not None else f"; {NO_RIG_RULE}")
        out.print(f"[dim]Runs: {rule}.[/dim]", soft_wrap=True)
    lost = [i for i in invs if i.losses]
    for i in lost:
        click.echo(f"thermrs: data loss: {i.path}: {'; '.join(i.losses)}", err=True)
    if lost:
        sys.exit(EXIT_DATA_LOSS)
