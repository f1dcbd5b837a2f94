"""The page of a watched run (``thermrs watch --html``): one self-contained HTML document,
rewritten atomically at each update, that reloads itself, so that it can be opened from
another machine on a share while the robot records. It renders a
:class:`thermrs.analyses.watch.WatchUpdate` only; the numbers are the watch's.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import polars as pl

from thermrs.report.blocks import Figure, Missing, Paragraph, Section, Table
from thermrs.report.figures import camera_colours, figure, legend, svg
from thermrs.report.render import to_html

#: A :class:`thermrs.analyses.watch.WatchUpdate` (the analyses stand below the report's rooms
#: only as the report's inputs: the page takes what it renders, whatever made it).
WatchUpdate = Any

__all__ = ["watch_page"]


def _f(x: Any, nd: int = 1) -> str:
    return "—" if x is None or (isinstance(x, float) and not np.isfinite(x)) else f"{x:.{nd}f}"


def _figure(u: WatchUpdate) -> str:
    """Drift so far (measured) and to come (predicted, its 95 % band), per chip axis."""
    run = u.run
    o = u.outlook
    cams = list(dict.fromkeys(run["camera"].to_list()))
    colours = camera_colours(cams)
    t0 = int(run["t_ns"].min())
    fig = figure(4.6)
    axes = fig.subplots(2, 1, sharex=True)
    for ax, axis in zip(axes, "uv", strict=True):
        for cam in cams:
            g = run.filter(pl.col("camera") == cam).sort("t_ns")
            h = (g["t_ns"].to_numpy() - t0) / 3.6e12
            m = g[f"{axis}_um"].to_numpy() - float(g[f"{axis}_um"][0])
            ax.plot(h, m, "-", lw=0.8, color=colours[cam], label=f"camera {cam} measured")
            if o is not None:
                c = o.curve.filter((pl.col("camera") == cam) & (pl.col("axis") == axis))
                x = c["hours"].to_numpy()
                ax.plot(
                    x,
                    c["predicted_um"].to_numpy(),
                    "--",
                    lw=1.2,
                    color=colours[cam],
                    label=f"camera {cam} foreseen",
                )
                ax.fill_between(
                    x,
                    c["lo_um"].to_numpy(),
                    c["hi_um"].to_numpy(),
                    color=colours[cam],
                    alpha=0.15,
                    lw=0,
                )
        if o is not None and o.tolerance_um is not None:
            for s in (-1, 1):
                ax.axhline(s * o.tolerance_um, color="black", lw=0.7, ls=":")
        name = "x" if axis == "u" else "y"
        ax.set_ylabel(f"drift along chip {name} ({axis}), µm")
        legend(ax)
    axes[1].set_xlabel("time since the run's first visit, h")
    return svg(fig)


def _sections(u: WatchUpdate) -> list[Section]:
    state = "closed: the recording is complete" if u.closed else "recording"
    summary = Section(
        "summary",
        "Now",
        [
            Paragraph(
                f"{u.recording}: {state}; {u.bytes_read:,} bytes read; the run so far "
                f"{u.hours:.2f} h, {u.run.height} visits with a spot."
            )
        ],
    )
    if u.waiting:
        summary.blocks.append(Missing(f"waiting: {u.waiting}"))
    if u.alpha is not None:
        a, se, src = u.alpha
        summary.blocks.append(
            Paragraph(f"α = {a * 1e6:.2f} ± {1.96 * se * 1e6:.2f} ×10⁻⁶/K (95 %), fitted on {src}.")
        )
    out = [summary]
    if u.run.height:
        drift = Section(
            "drift",
            "Drift so far and to come",
            [
                Figure(
                    "watch-drift",
                    "Measured drift from each camera's first visit of the run (solid); "
                    "foreseen by the forward model at the extrapolated temperatures (dashed) "
                    "with its 95 % band; the tolerance dotted.",
                    _figure(u),
                )
            ],
        )
        o = u.outlook
        if o is not None:
            rows = [
                [
                    str(r["camera"]),
                    str(r["axis"]),
                    _f(r["now_um"]),
                    f"{_f(r['end_um'])} ({_f(r['end_lo_um'])} to {_f(r['end_hi_um'])})",
                    "now" if r["already"] else _f(r["leaves_h"], 2),
                    f"{_f(r['leaves_lo_h'], 2)} to {_f(r['leaves_hi_h'], 2)}",
                ]
                for r in o.crossings.iter_rows(named=True)
            ]
            drift.blocks.append(
                Table(
                    f"Per camera and chip axis (µm; hours since the run's first visit; foreseen "
                    f"to {o.horizon_h:.1f} h; tolerance "
                    f"{'none given' if o.tolerance_um is None else f'±{o.tolerance_um:g} µm'}; "
                    "— : not before the horizon)",
                    [
                        "camera",
                        "axis",
                        "drift now",
                        "at the horizon (95 %)",
                        "leaves the tolerance (h)",
                        "95 % range (h)",
                    ],
                    rows,
                )
            )
            drift.blocks += [Paragraph(n) for n in o.notes]
        out.append(drift)
    if u.temperatures:
        trows = [[n, _f(t, 2)] for n, t in sorted(u.temperatures.items())]
        if u.outlook is not None:
            ends = {r["name"]: r for r in u.outlook.temperatures.iter_rows(named=True)}
            trows = [
                [
                    *r,
                    _f(ends[r[0]]["end_c"], 2) if r[0] in ends else "—",
                    _f(ends[r[0]]["tau_min"], 0) if r[0] in ends else "—",
                ]
                for r in trows
            ]
            cols = ["name", "now (°C)", "at the horizon (°C)", "τ (min)"]
        else:
            cols = ["name", "now (°C)"]
        out.append(Section("temperatures", "Temperatures", [Table("Latest readings", cols, trows)]))
    look = u.look
    diag: list[Any] = []
    if look is not None and hasattr(look, "message"):
        diag.append(Paragraph(str(look.message)))
    if u.diagnosis is not None:
        diag.append(Paragraph(f"The finished run's diagnosis: {u.diagnosis.summary}"))
    if diag:
        out.append(Section("diagnosis", "Diagnosis", diag))
    return out


def watch_page(u: WatchUpdate, *, refresh_s: int = 30) -> str:
    """The page of a watched run.

    Parameters
    ----------
    u
        The latest update.
    refresh_s
        Seconds after which the page reloads itself (0: never; a closed recording's page
        never does).

    Returns
    -------
    str
        One self-contained HTML document.
    """
    html = to_html(
        _sections(u), title=f"thermrs watch: {u.recording}", meta="closed" if u.closed else "live"
    )
    if refresh_s > 0 and not u.closed:
        html = html.replace("<head>", f'<head><meta http-equiv="refresh" content="{refresh_s}">', 1)
    return html
