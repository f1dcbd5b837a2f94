"""``thermrs watch``: follow a run while the robot records it."""

from __future__ import annotations

import re
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

from thermrs.cli.common import (
    EXIT_DATA_LOSS,
    TRAIN_HELP,
    console,
    file_tables,
    json_option,
    out_option,
    rig_option,
    run_file,
    say,
    table,
    writable,
    write_json,
)
from thermrs.errors import InputError

if TYPE_CHECKING:  # pragma: no cover
    from rich.console import RenderableType

    from thermrs.analyses.watch import WatchUpdate


def _duration_s(text: str | None) -> float | None:
    """``90s``, ``30m``, ``2h`` or seconds as a number."""
    if text is None:
        return None
    m = re.fullmatch(r"\s*([0-9.]+)\s*([smh]?)\s*", text)
    if not m:
        raise InputError(f"--until {text!r}: give a duration such as 90s, 30m or 2h")
    try:
        v = float(m[1])
    except ValueError:
        raise InputError(f"--until {text!r}: give a duration such as 90s, 30m or 2h") from None
    return v * {"": 1, "s": 1, "m": 60, "h": 3600}[m[2]]


def _f(x: Any, nd: int = 1) -> str:
    return "—" if x is None else f"{x:.{nd}f}"


def _view(u: WatchUpdate) -> RenderableType:
    """The terminal view of an update."""
    from rich.console import Group
    from rich.text import Text

    state = "closed" if u.closed else "recording"
    head = Text(
        f"{u.recording}: {state}; {u.bytes_read:,} bytes read; run so far {u.hours:.2f} h, "
        f"{u.run.height} visits"
    )
    parts: list[Any] = [head]
    if u.waiting:
        parts.append(Text(f"waiting: {u.waiting}", style="yellow"))
    if u.alpha is not None:
        a, se, src = u.alpha
        parts.append(Text(f"α = {a * 1e6:.2f} ± {1.96 * se * 1e6:.2f} ×10⁻⁶/K (95 %, {src})"))
    o = u.outlook
    if o is not None:
        tol = (
            "no tolerance given" if o.tolerance_um is None else f"tolerance ±{o.tolerance_um:g} µm"
        )
        t = table(
            f"Drift (µm from each camera's first visit); foreseen to {o.horizon_h:.1f} h; {tol}",
            [
                (c, "left" if c in ("camera", "axis") else "right")
                for c in (
                    "camera",
                    "axis",
                    "now",
                    "at horizon",
                    "95 %",
                    "leaves at (h)",
                    "95 % (h)",
                )
            ],
        )
        for r in o.crossings.iter_rows(named=True):
            t.add_row(
                str(r["camera"]),
                str(r["axis"]),
                _f(r["now_um"]),
                _f(r["end_um"]),
                f"{_f(r['end_lo_um'])} to {_f(r['end_hi_um'])}",
                "now" if r["already"] else _f(r["leaves_h"], 2),
                f"{_f(r['leaves_lo_h'], 2)} to {_f(r['leaves_hi_h'], 2)}",
            )
        parts.append(t)
        for n in o.notes:
            parts.append(Text(n, style="dim"))
    if u.temperatures:
        parts.append(
            Text(
                "temperatures: "
                + ", ".join(f"{n} {v:.2f} °C" for n, v in sorted(u.temperatures.items()))
            )
        )
    if u.look is not None and hasattr(u.look, "message"):
        parts.append(Text(f"sequential diagnosis: {u.look.message}", style="bold"))
    if u.diagnosis is not None:
        parts.append(Text(f"the finished run's diagnosis: {u.diagnosis.summary}"))
    return Group(*parts)


@click.command()
@click.argument("recording", type=click.Path(path_type=Path))
@rig_option
@click.option(
    "--train",
    "train",
    multiple=True,
    type=run_file,
    help="α for the outlook, and the sequential diagnosis's training runs. " + TRAIN_HELP,
)
@click.option(
    "--tolerance-um",
    type=click.FloatRange(min=0, min_open=True),
    default=None,
    help="Tolerance on the drift along either chip axis (µm): when it is left is foreseen.",
)
@click.option(
    "--hours",
    type=click.FloatRange(min=0, min_open=True),
    default=None,
    help="The run's planned length (h), the outlook's horizon [default: the longest "
    "--train run, else twice the run so far].",
)
@out_option(
    "Write the tables here (OUT.parquet and its siblings, as `thermrs extract -o`) when "
    "the recording closes; when stopped (Ctrl-C, --until) the tables so far, which the "
    "same command goes on from.",
    required=False,
)
@click.option(
    "--html",
    "html_path",
    type=click.Path(path_type=Path),
    default=None,
    help="A page rewritten atomically at each update (it reloads itself).",
)
@json_option("Write the latest update as JSON here (atomically, at each update).")
@click.option(
    "--every",
    "every_s",
    type=click.FloatRange(min=0.05),
    default=5.0,
    show_default=True,
    help="Seconds between reads while nothing is added.",
)
@click.option(
    "--until",
    "until",
    default=None,
    help="Stop after watching this long (90s, 30m, 2h); the tables so far go to -o.",
)
@click.option(
    "--look-every-h",
    type=click.FloatRange(min=0, min_open=True),
    default=1.0,
    show_default=True,
    help="With --train: hours of run between the sequential diagnosis's looks.",
)
@click.option(
    "--care-um",
    type=click.FloatRange(min=0, min_open=True),
    default=None,
    help="With --train: the smallest rms of drift (µm) you need to see; an effect-free "
    "verdict settles early only once every effect that large would have been named with 95 % "
    "power (else only at the plan's end).",
)
@click.option(
    "--designed",
    is_flag=True,
    help="A run `thermrs design` planned to separate rival effects: only `identified` "
    "settles it (an ambiguous verdict does not).",
)
@click.option(
    "--exclude",
    "exclude",
    multiple=True,
    help="Effects the sequential diagnosis never names (SPEC §6 names), as for diagnose.",
)
@click.option(
    "--diagnose/--no-diagnose",
    "diagnose",
    default=True,
    show_default=True,
    help="With --train: the sequential diagnosis and its stop rule.",
)
def watch(
    recording: Path, rig_path: Path, train: tuple[Path, ...], tolerance_um: float | None,
    hours: float | None, out_path: Path | None, html_path: Path | None,
    json_path: Path | None, every_s: float, until: str | None, look_every_h: float,
    care_um: float | None, designed: bool, exclude: tuple[str, ...], diagnose: bool,
) -> None:  # fmt: skip
    """Follow RECORDING (an MCAP file, a rosbag2 .db3, or a bag folder of either's parts)
    while it is written: the drift so far per camera and chip axis with the ROI temperatures,
    the forward model's drift to come with its 95 % band, when it leaves --tolerance-um, and
    with --train a sequential diagnosis that says when the answer is in. Each update reads
    only the bytes (a .db3: the rows) added since the last. Ends by itself when the recording
    is closed (exit 0; 3 if part of it was lost; a .db3 alone never says so), or at --until;
    Ctrl-C leaves the tables so far at -o (exit 130).
    """
    from rich.live import Live

    from thermrs.analyses.watch import watch as run_watch
    from thermrs.atomic import write_text
    from thermrs.report.watch_page import watch_page
    from thermrs.rig import load_rig

    writable(out_path, "-o", suffixes=(".parquet",))
    writable(html_path, "--html", suffixes=(".html",))
    writable(json_path, "--json")
    until_s = _duration_s(until)
    r = load_rig(rig_path)
    tables = file_tables(train, r, "--train")[0] if train else []
    updates = run_watch(
        recording,
        r,
        train=tables,
        tolerance_um=tolerance_um,
        hours=hours,
        out=out_path,
        poll_s=every_s,
        until_s=until_s,
        sequential=diagnose,
        look_every_h=look_every_h,
        care_um=care_um,
        settle_ambiguous=not designed,
        exclude=exclude,
    )
    last = None
    con = console()
    live = Live(console=con, auto_refresh=False) if con.is_terminal else None
    try:
        if live is not None:
            live.start()
        for u in updates:
            last = u
            if html_path is not None:
                write_text(html_path, watch_page(u, refresh_s=max(5, int(every_s * 2))))
            if json_path is not None:
                write_json(json_path, u.to_json())
            if live is not None:
                live.update(_view(u), refresh=True)
            else:
                _line(u)
    finally:
        if live is not None:
            live.stop()
    if last is None:
        return
    if not con.is_terminal:
        con.print(_view(last))
    for name, p in last.written.items():
        say(f"wrote {name}: {p}")
    if last.extraction is not None and last.extraction.report.data_loss:
        for loss in last.extraction.report.losses:
            say(f"data loss: {loss['detail']}")
        sys.exit(EXIT_DATA_LOSS)


def _line(u: WatchUpdate) -> None:
    """One line per update where the output is not a terminal (a log)."""
    o = u.outlook
    bits = [f"{u.hours:.2f} h", f"{u.run.height} visits", f"{u.bytes_read:,} B"]
    if u.waiting:
        bits.append(f"waiting: {u.waiting}")
    if o is not None:
        worst = max(o.crossings.iter_rows(named=True), key=lambda r: abs(r["end_um"]))
        bits.append(
            f"camera {worst['camera']} {worst['axis']}: {worst['now_um']:.1f} µm now, "
            f"{worst['end_um']:.1f} µm at {o.horizon_h:.1f} h"
        )
    if u.look is not None and hasattr(u.look, "message"):
        bits.append(str(u.look.message))
    click.echo("watch: " + "; ".join(bits))
