"""Repeatability cold against warm (ISO 9283-style)."""

from __future__ import annotations

from collections.abc import Mapping

import polars as pl

from thermrs.numbers import fmt
from thermrs.report.blocks import Figure, Missing, Paragraph, Section, Table
from thermrs.report.data import ReportData
from thermrs.report.figures import fig_iso

__all__ = ["section"]


def section(d: ReportData, colours: Mapping[str, str]) -> Section:
    """The ISO 9283 section: RP cold and warm, dAP, dRP and settling per run and camera."""
    s = Section("iso9283", "Repeatability cold against warm (ISO 9283-style)")
    spans = _spans(d)
    s.blocks.append(
        Paragraph(
            f"{d.iso['method']}. Windows of {d.iso['window']} consecutive visits per camera"
            + (f" ({spans} here)" if spans else "")
            + "; RP = l̄ + 3·S_l, the spread of a window's visits about their barycentre; cold: "
            "the run's first window, warm: its last; settled: the barycentre stays within "
            f"{fmt(d.iso['tolerance_um'], 1)} µm of the final one (as `thermrs drift --json` "
            "gives them). A spot that drifts during a window counts as spread: RP cold, taken "
            "while the robot warms up, holds the warm-up drift inside its window besides the "
            "repeatability, and dRP compares it with a warm window that drifts less."
        )
    )
    win = d.iso_windows
    rows = [
        [
            r["run"],
            r["camera"],
            _minutes(win, r["run"], r["camera"], first=True),
            fmt(r["rp_cold_um"]),
            _minutes(win, r["run"], r["camera"], first=False),
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
                "cold window (min from the run's first visit)",
                "RP cold (µm)",
                "warm window (min)",
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
        s.blocks.append(Missing(f"No run has a window of {d.iso['window']} visits: no figure."))
    return s


def _run_starts(win: pl.DataFrame) -> dict[str, int]:
    """Each run's first window start (ns): the origin of the windows' minutes."""
    return dict(win.group_by("run").agg(pl.col("t_start_ns").min()).iter_rows())


def _minutes(win: pl.DataFrame, run: str, camera: str, *, first: bool) -> str:
    """A camera's first (cold) or last (warm) window of a run, as minutes from the run's
    first window: ``0–45``."""
    w = win.filter((pl.col("run") == run) & (pl.col("camera") == camera)).sort("window")
    if w.height == 0:
        return "—"
    row = w.row(0 if first else -1, named=True)
    t0 = _run_starts(win)[run]
    return f"{(row['t_start_ns'] - t0) / 60e9:.0f}–{(row['t_end_ns'] - t0) / 60e9:.0f}"


def _spans(d: ReportData) -> str:
    """How long the windows last, first visit to last: ``42–47 min``."""
    w = d.iso_windows
    if w.height == 0:
        return ""
    m = ((w["t_end_ns"] - w["t_start_ns"]) / 60e9).to_list()
    lo, hi = min(m), max(m)
    return f"{lo:.0f} min" if round(lo) == round(hi) else f"{lo:.0f}–{hi:.0f} min"
