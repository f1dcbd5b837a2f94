"""The report's figures, drawn with matplotlib as SVG text (inline in the HTML, files beside
the Markdown).

Conventions of every figure: time in hours since the run's first visit, drift in µm,
temperatures in °C, one colour per camera throughout the report (:func:`camera_colours`),
temperature series in colours no camera uses, labelled axes and a legend. matplotlib is
imported here only, so that the command line starts without it.
"""

from __future__ import annotations

import io
import re
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
import polars as pl

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = [
    "camera_colours",
    "fig_diagnosis",
    "fig_iso",
    "fig_prediction",
    "fig_rig",
    "fig_run",
    "figure",
    "legend",
    "svg",
]

#: Cameras take these in the rig's order (matplotlib's tab10, first five).
CAMERA_PALETTE = ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd")
#: Temperatures take these (tab10's last five: no camera uses them).
TEMPERATURE_PALETTE = ("#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf")
#: At most this many points per plotted line (the SVG stays small).
MAX_POINTS = 500


def camera_colours(cameras: Sequence[str]) -> dict[str, str]:
    """One colour per camera, in the rig's order."""
    return {c: CAMERA_PALETTE[i % len(CAMERA_PALETTE)] for i, c in enumerate(cameras)}


def temperature_colours(names: Sequence[str]) -> dict[str, str]:
    """One colour per temperature series (ROI or ambient)."""
    return {n: TEMPERATURE_PALETTE[i % len(TEMPERATURE_PALETTE)] for i, n in enumerate(names)}


def figure(height_in: float, width_in: float = 9.5) -> Figure:
    """A blank figure in the report's style (``height_in`` by ``width_in`` inches)."""
    import matplotlib

    matplotlib.rcParams.update(
        {
            "svg.fonttype": "none",  # text stays text: smaller, searchable
            "svg.hashsalt": "thermrs",  # the same figure gives the same bytes
            "font.size": 9,
            "axes.grid": True,
            "grid.alpha": 0.3,
            "axes.spines.top": False,
            "axes.spines.right": False,
            "legend.fontsize": 8,
            "legend.frameon": False,
        }
    )
    from matplotlib.figure import Figure

    return Figure(figsize=(width_in, height_in), layout="constrained")


def svg(fig: Figure) -> str:
    """``fig`` as SVG text for inline HTML: no prolog or metadata, the same bytes every time,
    coordinates to 0.01 pt."""
    from matplotlib.backends.backend_mixed import MixedModeRenderer
    from matplotlib.backends.backend_svg import FigureCanvasSVG, RendererSVG

    # What ``FigureCanvasSVG.print_svg`` does, with two savings (the same bytes): the figure is
    # drawn once (savefig draws it twice when it has a layout engine: once without output to
    # lay it out, then again to write it; here the constrained layout runs at the start of the
    # one draw), and it is laid out with the renderer it is drawn with, so each text is
    # measured once (matplotlib caches text sizes per renderer).
    buf = io.StringIO()
    dpi = fig.dpi
    fig.dpi = 72  # SVG is in points
    try:
        w, h = fig.get_size_inches()
        vector = RendererSVG(  # type: ignore[no-untyped-call]
            w * 72, h * 72, buf, image_dpi=dpi, metadata={"Date": None, "Creator": None}
        )
        renderer: Any = MixedModeRenderer(fig, w, h, dpi, vector)  # type: ignore[no-untyped-call]

        class Canvas(FigureCanvasSVG):
            def get_renderer(self) -> Any:  # what the layout measures text with
                return renderer

        Canvas(fig)
        fig.draw(renderer)
        renderer.finalize()
    finally:
        fig.dpi = dpi
    text = buf.getvalue()
    # Inline in HTML: drop the XML prolog and the DOCTYPE.
    start = text.find("<svg")
    text = text[start:] if start >= 0 else text
    # The RDF metadata block says only "made by matplotlib": drop it.
    text = re.sub(r"\s*<metadata>.*?</metadata>", "", text, count=1, flags=re.S)
    # Path coordinates to 0.01 pt (matplotlib writes 6 decimals): a third smaller, invisible.
    return re.sub(r'\sd="[^"]*"', lambda m: _COORD.sub(r"\1", m.group(0)), text)


def legend(ax: Any) -> None:
    """The legend outside the plot, on the right: it never hides data (and matplotlib's
    "best" place, which searches every point, is slow)."""
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)


_COORD = re.compile(r"(\d\.\d{2})\d+")


def _thin(x: np.ndarray, *ys: np.ndarray) -> tuple[np.ndarray, ...]:
    """Every k-th point so that at most :data:`MAX_POINTS` remain (plots only; numbers never
    come from thinned series)."""
    k = max(1, int(np.ceil(len(x) / MAX_POINTS)))
    return (x[::k], *(y[::k] for y in ys))


def _hours(t_ns: np.ndarray, t0_ns: int) -> np.ndarray:
    return (t_ns.astype(np.float64) - float(t0_ns)) / 3.6e12


def _curve_values(row: Mapping[str, Any], t_ns: np.ndarray) -> np.ndarray | None:
    """A heating curve row evaluated at ``t_ns`` (None where it has no fit)."""
    from thermrs.numbers import tau_determined

    y0, a, tau = row.get("y0"), row.get("a"), row.get("tau_min")
    if not tau_determined(tau, row.get("tau_min_se")):
        return None  # no heating curve: τ not determined
    t0 = row.get("t_start_ns")
    if y0 is None or t0 is None:
        return None
    if not a or tau is None or not np.isfinite(tau):
        return np.full(len(t_ns), float(y0))
    t_s = (t_ns.astype(np.float64) - float(t0)) / 1e9
    return np.asarray(float(y0) + float(a) * np.exp(-t_s / (60.0 * float(tau))))


def fig_run(
    table: pl.DataFrame,
    curves: pl.DataFrame,
    colours: Mapping[str, str],
    tcol: Mapping[str, str],
    *,
    temperatures: pl.DataFrame | None = None,
) -> str:
    """The paper's Figure 5 for one run: the spot's drift along the chip's u (x) and v (y) axis
    per camera, and the ROI temperatures, on one time axis; fitted heating curves dashed.

    ``temperatures`` is the run's long table of readings (plotted at every reading); without
    it the run table's values at the visit times are plotted.
    """
    t = table.sort("t_ns")
    t0 = int(t["t_ns"].min())  # type: ignore[arg-type]
    temp_names = sorted(c[: -len("_c")] for c in t.columns if c.endswith("_c"))
    fig = figure(6.4)
    axes = fig.subplots(3, 1, sharex=True)
    cams = [c for c in colours if c in set(t["camera"].to_list())]
    for ax_i, axis in enumerate("uv"):
        ax = axes[ax_i]
        for cam in cams:
            tc = t.filter(pl.col("camera") == cam)
            x = _hours(tc["t_ns"].to_numpy(), t0)
            y = tc[f"drift_{axis}_um"].to_numpy().astype(np.float64)
            xs, ys = _thin(x, y)
            ax.plot(xs, ys, "-", lw=0.8, color=colours[cam], label=f"camera {cam} (measured)")
            row = curves.filter(
                (pl.col("kind") == "drift") & (pl.col("camera") == cam) & (pl.col("axis") == axis)
            )
            if row.height:
                fit = _curve_values(row.row(0, named=True), tc["t_ns"].to_numpy())
                if fit is not None:
                    xf, yf = _thin(x, fit)
                    ax.plot(xf, yf, "--", lw=1.2, color=colours[cam], label=f"camera {cam} (fit)")
        name = "x" if axis == "u" else "y"
        ax.set_ylabel(f"drift along chip {name} ({axis}), µm")
        legend(ax)
    ax = axes[2]
    if not temp_names:
        ax.text(
            0.5, 0.5, "no temperature readings", ha="center", va="center", transform=ax.transAxes
        )
    for name in temp_names:
        if temperatures is not None and temperatures.height:
            s = temperatures.filter(pl.col("name") == name).sort("t_ns")
            col = "peak_c" if "peak_c" in s.columns else "temperature_c"
            x = _hours(s["t_ns"].to_numpy(), t0)
            y = s[col].to_numpy().astype(np.float64)
        else:
            per = t.unique("t_ns", keep="first", maintain_order=True)
            x = _hours(per["t_ns"].to_numpy(), t0)
            y = per[f"{name}_c"].to_numpy().astype(np.float64)
        xs, ys = _thin(x, y)
        ax.plot(xs, ys, "-", lw=1.0, color=tcol[name], label=name)
        row = curves.filter((pl.col("kind") == "temperature") & (pl.col("series") == name))
        if row.height:
            tt = t.unique("t_ns", keep="first", maintain_order=True)["t_ns"].to_numpy()
            fit = _curve_values(row.row(0, named=True), tt)
            if fit is not None:
                xf, yf = _thin(_hours(tt, t0), fit)
                ax.plot(xf, yf, "--", lw=1.0, color=tcol[name], label=f"{name} (fit)")
    ax.set_ylabel("temperature, °C")
    ax.set_xlabel("time since the run's first visit, h")
    if temp_names:
        legend(ax)
    return svg(fig)


def fig_overview(
    runs: Sequence[tuple[str, pl.DataFrame]],
    colours: Mapping[str, str],
    temperatures: Sequence[str],
    tcol: Mapping[str, str],
) -> str:
    """Every run side by side on a broken time axis (hours since each run's first visit; a
    panel per run, as wide as the run is long): each camera's drift along chip x (u, solid)
    and y (v, dotted), anchored at the run's first visit, and the temperatures the model
    expands with. Runs recorded days apart are not slivers of one long axis, and runs that
    share a clock are not drawn over each other."""
    spans = []
    for _, t in runs:
        lo, hi = int(t["t_ns"].min()), int(t["t_ns"].max())  # type: ignore[arg-type]
        spans.append(max((hi - lo) / 3.6e12, 1e-3))
    fig = figure(4.2)
    axes = fig.subplots(
        2, len(runs), sharey="row", squeeze=False, height_ratios=[3, 2], width_ratios=spans,
        gridspec_kw={"wspace": 0.06},
    )  # fmt: skip
    labelled: set[str] = set()
    for j, (name, t) in enumerate(runs):
        t = t.sort("t_ns")
        t0 = int(t["t_ns"].min())  # type: ignore[arg-type]
        top, bottom = axes[0][j], axes[1][j]
        top.set_title(name, fontsize=8)
        for cam in colours:
            tc = t.filter(pl.col("camera") == cam)
            if not tc.height:
                continue
            x = _hours(tc["t_ns"].to_numpy(), t0)
            for axis, ls in (("u", "-"), ("v", ":")):
                y = tc[f"drift_{axis}_um"].to_numpy().astype(np.float64)
                xs, ys = _thin(x, y)
                label = f"camera {cam}, chip {'x' if axis == 'u' else 'y'} ({axis})"
                top.plot(xs, ys, ls, lw=1.0, color=colours[cam],
                         label=None if label in labelled else label)  # fmt: skip
                labelled.add(label)
        per = t.unique("t_ns", keep="first", maintain_order=True)
        x = _hours(per["t_ns"].to_numpy(), t0)
        for n in temperatures:
            if f"{n}_c" not in per.columns:
                continue
            xs, ys = _thin(x, per[f"{n}_c"].to_numpy().astype(np.float64))
            bottom.plot(xs, ys, "-", lw=1.0, color=tcol[n], label=None if n in labelled else n)
            labelled.add(n)
        top.axhline(0.0, color="black", lw=0.5)
        top.tick_params(labelbottom=False)
        for ax in (top, bottom):
            ax.set_xlim(0, spans[j])
            if j > 0:  # the break between runs: no spine, no y labels
                ax.spines["left"].set_linestyle((0, (2, 2)))
                ax.tick_params(labelleft=False)
    axes[0][0].set_ylabel("drift from the run's\nfirst visit, µm")
    axes[1][0].set_ylabel("temperature, °C")
    fig.supxlabel("hours since each run's first visit (runs side by side, axis broken between)",
                  fontsize=8)  # fmt: skip
    for row in axes:  # one legend per row, right of the last run, from every panel
        handles, labels = [], []
        for ax in row:
            h, lab = ax.get_legend_handles_labels()
            handles += h
            labels += lab
        if handles:
            row[-1].legend(handles, labels, loc="upper left", bbox_to_anchor=(1.01, 1.0),
                           borderaxespad=0.0)  # fmt: skip
    return svg(fig)


def fig_prediction(series: pl.DataFrame, colours: Mapping[str, str], run: str) -> str:
    """Predicted against measured drift of one run, both chip axes, and the residual
    (measured − predicted)."""
    s = series.filter(pl.col("run") == run).sort("t_ns")
    t0 = int(s["t_ns"].min())  # type: ignore[arg-type]
    fig = figure(5.6)
    axes = fig.subplots(3, 1, sharex=True)
    cams = [c for c in colours if c in set(s["camera"].to_list())]
    for ax_i, axis in enumerate("uv"):
        ax = axes[ax_i]
        for cam in cams:
            g = s.filter(pl.col("camera") == cam)
            x = _hours(g["t_ns"].to_numpy(), t0)
            m = g[f"measured_{axis}_um"].to_numpy().astype(np.float64)
            p = g[f"predicted_{axis}_um"].to_numpy().astype(np.float64)
            xs, ms_, ps = _thin(x, m, p)
            ax.plot(
                xs, ms_, "-", lw=0.7, alpha=0.6, color=colours[cam], label=f"camera {cam} measured"
            )
            ax.plot(xs, ps, "--", lw=1.4, color=colours[cam], label=f"camera {cam} predicted")
        name = "x" if axis == "u" else "y"
        ax.set_ylabel(f"drift along chip {name} ({axis}), µm")
        legend(ax)
    ax = axes[2]
    for cam in cams:
        g = s.filter(pl.col("camera") == cam)
        x = _hours(g["t_ns"].to_numpy(), t0)
        ru = g["residual_u_um"].to_numpy().astype(np.float64)
        rv = g["residual_v_um"].to_numpy().astype(np.float64)
        xs, rus, rvs = _thin(x, ru, rv)
        ax.plot(xs, rus, "-", lw=0.8, color=colours[cam], label=f"camera {cam}, u")
        ax.plot(xs, rvs, ":", lw=1.0, color=colours[cam], label=f"camera {cam}, v")
    ax.axhline(0.0, color="black", lw=0.6)
    ax.set_ylabel("measured − predicted, µm")
    ax.set_xlabel("time since the run's first visit, h")
    legend(ax)
    return svg(fig)


def fig_iso(windows: pl.DataFrame, colours: Mapping[str, str]) -> str:
    """ISO 9283-style RP and dAP per window of visits against time, per camera (colour) and
    run (line style)."""
    fig = figure(4.4)
    axes = fig.subplots(1, 2)
    styles = ("-", "--", ":", "-.")
    runs = list(dict.fromkeys(windows["run"].to_list())) if windows.height else []
    for ri, run in enumerate(runs):
        w = windows.filter(pl.col("run") == run)
        t0 = int(w["t_start_ns"].min())  # type: ignore[arg-type]
        for cam in colours:
            g = w.filter(pl.col("camera") == cam).sort("window")
            if not g.height:
                continue
            mid = (g["t_start_ns"].to_numpy() + g["t_end_ns"].to_numpy()) // 2
            x = _hours(mid, t0)
            ls = styles[ri % len(styles)]
            lab = f"camera {cam}, {run}"
            axes[0].plot(x, g["rp_um"].to_numpy(), ls, lw=1.0, color=colours[cam], label=lab)
            axes[1].plot(x, g["dap_um"].to_numpy(), ls, lw=1.0, color=colours[cam], label=lab)
    axes[0].set_ylabel("RP per window, µm")
    axes[1].set_ylabel("dAP from the cold window, µm")
    for ax in axes:
        ax.set_xlabel("time since the run's first visit, h")
        if runs:
            legend(ax)
    return svg(fig)


def fig_diagnosis(residuals: pl.DataFrame, colours: Mapping[str, str]) -> str:
    """Residuals of the held-out runs before (nominal model) and after the chosen effect."""
    r = residuals.filter(pl.col("role") == "holdout") if "role" in residuals.columns else residuals
    runs = list(dict.fromkeys(r["run"].to_list()))
    fig = figure(2.4 * max(1, len(runs)) + 0.4)
    axes = np.atleast_1d(fig.subplots(max(1, len(runs)), 1, sharex=True))
    for ax, run in zip(axes, runs, strict=False):
        g = r.filter(pl.col("run") == run)
        for cam in colours:
            for axis, ls in (("u", "-"), ("v", ":")):
                h = g.filter((pl.col("camera") == cam) & (pl.col("axis") == axis)).sort("t_h")
                if not h.height:
                    continue
                x = h["t_h"].to_numpy().astype(np.float64)
                b = h["baseline_um"].cast(pl.Float64).to_numpy()
                xs, bs = _thin(x, b)
                ax.plot(
                    xs,
                    bs,
                    ls,
                    lw=0.8,
                    color=colours[cam],
                    alpha=0.45,
                    label=f"camera {cam} {axis}, nominal",
                )
                if "after_um" in h.columns and h["after_um"].null_count() < h.height:
                    a = h["after_um"].cast(pl.Float64).fill_null(np.nan).to_numpy()
                    xs, as_ = _thin(x, a)
                    ax.plot(
                        xs,
                        as_,
                        ls,
                        lw=1.4,
                        color=colours[cam],
                        label=f"camera {cam} {axis}, with the effect",
                    )
        ax.axhline(0.0, color="black", lw=0.6)
        ax.set_title(f"held-out run {run}", fontsize=9)
        ax.set_ylabel("residual, µm")
        legend(ax)
    axes[-1].set_xlabel("time since the run's first visit, h")
    return svg(fig)


def fig_rig(
    rig_view: Mapping[str, Any],
    sizes: Mapping[str, tuple[int, int]],
    poses: Mapping[str, str],
    colours: Mapping[str, str],
) -> str:
    """Where the laser meets each chip at the camera's own pose: the chip outline (pixels) and
    the spot."""
    cams = list(colours)
    fig = figure(3.0, 2.6 * max(1, len(cams)) + 0.4)
    axes = np.atleast_1d(fig.subplots(1, max(1, len(cams))))
    for ax, cam in zip(axes, cams, strict=False):
        w, h = sizes[cam]
        spot = rig_view["poses"][poses[cam]]["spot_px"].get(cam)
        ax.add_patch(_rect(w, h))
        if spot is not None:
            ax.plot(
                [spot[0]],
                [spot[1]],
                "o",
                color=colours[cam],
                ms=7,
                label=f"spot ({spot[0]:.1f}, {spot[1]:.1f}) px",
            )
        ax.plot([(w - 1) / 2], [(h - 1) / 2], "+", color="black", ms=8, label="chip centre")
        ax.set_xlim(-0.05 * w, 1.05 * w)
        ax.set_ylim(1.05 * h, -0.05 * h)  # rows grow downwards
        ax.set_aspect("equal")
        ax.set_title(f"camera {cam} at pose {poses[cam]}", fontsize=9)
        ax.set_xlabel("x, px")
        ax.set_ylabel("y, px")
        ax.legend(loc="lower center", bbox_to_anchor=(0.5, -0.62))
    return svg(fig)


def _rect(w: int, h: int) -> Any:
    from matplotlib.patches import Rectangle

    return Rectangle((-0.5, -0.5), w, h, fill=False, lw=1.0, color="black")
