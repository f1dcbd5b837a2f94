"""Heating curves: first-order fits to every temperature and drift series."""

from __future__ import annotations

from thermrs.numbers import fmt, tau_determined
from thermrs.report.blocks import Paragraph, Section, Table
from thermrs.report.data import ReportData
from thermrs.report.sections.common import axis_name

__all__ = ["section"]


def section(d: ReportData) -> Section:
    """The heating-curves section: the fitted curves of every series with their errors."""
    s = Section("heating", "Heating curves")
    s.blocks.append(
        Paragraph(
            "First-order curves y = y₀ + A·e^(−t/τ) fitted per run to every ROI temperature (at "
            "the visit times) and to each camera's drift along both chip axes, with standard "
            "errors (as `thermrs drift --json` gives them)."
        )
    )
    rows = []
    for row in d.curves.iter_rows(named=True):
        fitted = row["phase"] is not None and tau_determined(row["tau_min"], row["tau_min_se"])
        if row["phase"] is not None and not fitted:
            row = {**row, "phase": None, "note": "no heating curve: τ not determined"}
            row |= {k: None for k in ("y0", "y0_se", "a", "a_se", "tau_min", "tau_min_se", "rms")}
        if row["kind"] == "temperature":
            series, unit = f"{row['series']} (°C)", "°C"
        else:
            series, unit = f"drift camera {row['camera']} {axis_name(row['axis'])} (µm)", "µm"
        del unit
        rows.append(
            [
                row["run"],
                series,
                fmt(row["y0"]),
                fmt(row["y0_se"]),
                fmt(row["a"]),
                fmt(row["a_se"]),
                fmt(row["tau_min"], 1),
                fmt(row["tau_min_se"], 1),
                fmt(row["rms"], 3),
                row["phase"] or "no fit",
                row["note"] or "",
            ]
        )
    s.blocks.append(
        Table(
            "Heating curves y = y₀ + A·e^(−t/τ) (± one standard error)",
            [
                "run",
                "series",
                "y₀",
                "± y₀",
                "A",
                "± A",
                "τ (min)",
                "± τ (min)",
                "rms",
                "phase",
                "note",
            ],
            rows,
        )
    )
    return s
