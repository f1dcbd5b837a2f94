"""Beside the field's regressions: the physical models and regressions of the drift on the
temperatures, fitted on the same training runs and scored on the same held-out runs
(:func:`thermrs.analyses.baselines.compare_baselines`), as a subsection of the diagnosis."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
import polars as pl

from thermrs.numbers import fmt
from thermrs.report.blocks import Figure, Paragraph, Section, Table

__all__ = ["subsection"]

#: Line styles of the models in the figure: the physical ones first, then each regression.
_PHYSICAL = {"nominal": ("#7f7f7f", "--", 1.0), "diagnosed": ("#000000", "-", 1.6)}
_REGRESSION_COLOURS = ("#d62728", "#ff7f0e", "#2ca02c", "#17becf", "#9467bd", "#8c564b")


def subsection(comparison: Any) -> Section:
    """The subsection: what was compared and how, the table, what it says, the figure."""
    from thermrs.diagnose.baselines import said

    doc = comparison.to_json()
    comp = doc["baselines_comparison"]
    s = Section("baselines", "Beside regressions on the temperatures")
    s.blocks.append(
        Paragraph(
            "Would a regression of the drift on the temperatures have done as well as the "
            "physical model? Thermal compensation is often fitted that way: least squares on a "
            "few temperature sensors, LASSO to choose among them, boosted trees. Here each such "
            "regression was fitted, per camera and chip axis, on the same training runs as the "
            "physical model, and scored on the same held-out runs the same way: the drift "
            "since a run's first visit, each held-out run's offset (its unknown mounting) "
            "removed, the rms over both chip axes of every camera. The low-pass models see the "
            "temperatures through first-order filters of 10, 30 and 90 minutes and the time "
            "since the run began; where a model has a penalty it was chosen by "
            f"cross-validation {comp['cv'] or ''}. Lower is better; the noise floor, "
            f"{fmt(comp['noise_floor_um'])} µm, is what no model can go below. 'Parameters' "
            "counts what each fitted: α and the effect's parameters for the physical models; "
            "the coefficients (or the trees' leaves) over both cameras and axes for a "
            "regression."
        )
    )
    rows = [comp["nominal"], *([comp["diagnosed"]] if comp["diagnosed"] else []), *doc["baselines"]]
    runs = [r["run"] for r in rows[0]["per_run"]]
    cols = ["model", "what", "parameters", "held-out rms, µm [95 %]"]
    cols += [f"{r}, µm" for r in runs]
    if comp["diagnosed"]:
        cols.append("minus the diagnosed model, µm [95 %]")
    body = []
    from thermrs.diagnose.baselines import row_cells

    for r in rows:
        body.append(row_cells(r, with_diagnosed=bool(comp["diagnosed"]), num=fmt))
    s.blocks.append(
        Table(
            "Held-out rms of the physical models and of each regression (95 % intervals: a "
            "block bootstrap of whole cycles, the same draws for every model)",
            cols,
            body,
        )
    )
    s.blocks.append(Paragraph(said(doc)))
    s.blocks.append(
        Figure(
            "baselines",
            "The held-out drift (dots, its offset removed) and what each model predicts for it: "
            "the nominal model (grey, dashed), the diagnosed model (black) and each regression "
            "(colours), per held-out run, camera and chip axis. The vertical axis follows the "
            "drift; a model that leaves it is off by more than the drift's own range.",
            fig_baselines(comparison.series, [r["name"] for r in rows]),
        )
    )
    return s


def fig_baselines(series: pl.DataFrame, models: list[str]) -> str:
    """Per held-out run and camera (rows) and chip axis (columns): the measured drift and each
    model's prediction of it."""
    from thermrs.report.figures import _thin, figure, legend, svg

    h = series.filter(pl.col("role") == "holdout")
    keys = h.select("run", "camera").unique(maintain_order=True).rows()
    fig = figure(2.2 * max(1, len(keys)) + 0.5)
    axes = np.atleast_2d(fig.subplots(max(1, len(keys)), 2, sharex="row", squeeze=False))
    colours = _colours(models)
    for i, (run, cam) in enumerate(keys):
        for j, axis in enumerate(("u", "v")):
            ax = axes[i, j]
            g = h.filter(
                (pl.col("run") == run) & (pl.col("camera") == cam) & (pl.col("axis") == axis)
            ).sort("t_h")
            x = g["t_h"].to_numpy().astype(np.float64)
            y = g["measured_um"].to_numpy().astype(np.float64)
            xs, ys = _thin(x, y)
            ax.plot(xs, ys, ".", ms=2.5, color="#444444", label="measured")
            for m in models:
                c, ls, lw = colours[m]
                p = g[f"{m}_um"].to_numpy().astype(np.float64)
                xs, ps = _thin(x, p)
                ax.plot(xs, ps, ls, color=c, lw=lw, label=m)
            span = float(np.ptp(y)) if len(y) else 1.0
            lo, hi = (float(np.min(y)), float(np.max(y))) if len(y) else (-1.0, 1.0)
            ax.set_ylim(lo - 0.35 * span - 1.0, hi + 0.35 * span + 1.0)
            ax.set_title(f"held-out run {run}, camera {cam}, chip {axis}", fontsize=9)
            if j == 0:
                ax.set_ylabel("drift, µm")
            if i == len(keys) - 1:
                ax.set_xlabel("time since the run began, h")
    legend(axes[0, 1])
    return svg(fig)


def _colours(models: list[str]) -> Mapping[str, tuple[str, str, float]]:
    out: dict[str, tuple[str, str, float]] = {}
    k = 0
    for m in models:
        if m in _PHYSICAL:
            out[m] = _PHYSICAL[m]
        else:
            out[m] = (_REGRESSION_COLOURS[k % len(_REGRESSION_COLOURS)], "-", 0.9)
            k += 1
    return out
