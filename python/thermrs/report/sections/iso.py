"""Repeatability cold against warm (ISO 9283-style)."""

from __future__ import annotations

from collections.abc import Mapping

from thermrs.iso9283 import LABEL
from thermrs.numbers import fmt
from thermrs.report.blocks import Figure, Missing, Paragraph, Section, Table
from thermrs.report.data import ISO_TOLERANCE_UM, ISO_WINDOW, ReportData
from thermrs.report.figures import fig_iso

__all__ = ["section"]


def section(d: ReportData, colours: Mapping[str, str]) -> Section:
    """The ISO 9283 section: RP cold and warm, dAP, dRP and settling per run and camera."""
    s = Section("iso9283", "Repeatability cold against warm (ISO 9283-style)")
    s.blocks.append(
        Paragraph(
            f"{LABEL}. Windows of {ISO_WINDOW} visits per camera; RP = l̄ + 3·S_l; cold: the "
            f"run's first window, warm: its last; settled: the barycentre stays within "
            f"{fmt(ISO_TOLERANCE_UM, 1)} µm of the final one (as `thermrs drift --json` gives "
            "them)."
        )
    )
    rows = [
        [
            r["run"],
            r["camera"],
            fmt(r["rp_cold_um"]),
            fmt(r["rp_warm_um"]),
            fmt(r["dap_um"]),
            fmt(r["drp_um"], 2, sign=True),
            fmt(r["settle_min"], 1),
            str(r["n_windows"]),
            r.get("note") or "",
        ]
        for r in d.iso["summary"]
    ]
    s.blocks.append(
        Table(
            "ISO 9283-style figures per run and camera",
            [
                "run",
                "camera",
                "RP cold (µm)",
                "RP warm (µm)",
                "dAP (µm)",
                "dRP (µm)",
                "settled after (min)",
                "windows",
                "note",
            ],
            rows,
        )
    )
    if d.iso_windows.height:
        s.blocks.append(
            Figure(
                "iso9283",
                "RP per window and the barycentre's distance from the cold window (dAP), per "
                "camera (colour) and run (line style).",
                fig_iso(d.iso_windows, colours),
            )
        )
    else:
        s.blocks.append(Missing(f"No run has a window of {ISO_WINDOW} visits: no figure."))
    return s
