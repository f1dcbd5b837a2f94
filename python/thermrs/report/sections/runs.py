"""Drift and temperatures per run (the paper's Figure 5 for every run)."""

from __future__ import annotations

from collections.abc import Mapping

import polars as pl

from thermrs.report.blocks import Figure, Missing, Paragraph, Section
from thermrs.report.data import ReportData
from thermrs.report.figures import fig_run
from thermrs.report.sections.common import series_colours

__all__ = ["section"]


def section(d: ReportData, colours: Mapping[str, str]) -> Section:
    """The runs section: one figure per run, drift and temperatures on one time axis."""
    s = Section("runs", "Drift and temperatures per run")
    s.blocks.append(
        Paragraph(
            "The paper's Figure 5 for every run: each camera's spot drift along the chip's x (u) "
            "and y (v) axis, anchored at the run's first visit, with the ROI temperatures on "
            "the same time axis; dashed: the fitted first-order heating curves."
        )
    )
    for run in d.runs:
        sub = Section(f"run-{run.name}", f"Run {run.name}")
        if not run.roi_names:
            sub.blocks.append(
                Missing(
                    f"No thermal readings in {run.name}"
                    + ("" if d.rig.thermal_topic else " (the rig names no thermal topic)")
                    + ": the temperature panel is empty."
                )
            )
        curves = d.curves.filter(pl.col("run") == run.name)
        sub.blocks.append(
            Figure(
                f"run-{run.name}",
                f"{run.name}: drift along chip x (u) and y (v) per camera, ROI temperatures; "
                "time since the run's first visit.",
                fig_run(
                    run.table, curves, colours, series_colours(d), temperatures=run.temperatures
                ),
            )
        )
        s.subsections.append(sub)
    return s
