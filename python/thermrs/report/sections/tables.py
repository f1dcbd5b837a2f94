"""Tables 4, 6 and 7: each run's temperatures and drift, α per estimator, and predicted against
measured end drift.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from thermrs.numbers import end_error, fmt, fmt_alpha
from thermrs.paper import load_paper_data
from thermrs.report.blocks import Missing, Section, Table
from thermrs.report.data import ReportData
from thermrs.report.sections.common import join

__all__ = ["section"]


def section(d: ReportData) -> Section:
    """Table 4 (beside the paper's, for the simulated paper runs), Table 6 and Table 7."""
    s = Section("tables", "Tables 4, 6 and 7")
    s.blocks.append(_table4(d))
    if d.paper_reference:
        s.blocks.append(_paper_table4())
    if d.fit is None:
        s.blocks.append(Missing(d.fit_note or "α was not fitted: no Table 6 or 7."))
        return s
    s.blocks.append(_table6(d, d.fit))
    s.blocks.append(_table7(d))
    return s


def _table4(d: ReportData) -> Table:
    """Table 4-style: each run's temperatures at its first and last visit, drift at its last."""
    cams = [c.name for c in d.rig.cameras]
    temps = sorted({n for r in d.runs for n in r.roi_names})
    cols = ["run", "hours", "visits"]
    for n in temps:
        cols += [f"{n} first → last (°C)", f"Δ{n} (K)"]
    for c in cams:
        cols += [f"{c} Δu (µm)", f"{c} Δv (µm)"]
    rows = []
    for row in d.table4.iter_rows(named=True):
        cells = [row["run"], fmt(row["hours"], 1), str(row["visits"])]
        for n in temps:
            a, b = row.get(f"{n}_start_c"), row.get(f"{n}_end_c")
            cells += [
                f"{fmt(a)} → {fmt(b)}",
                fmt(None if a is None or b is None else b - a, 2, sign=True),
            ]
        for c in cams:
            cells += [fmt(row.get(f"{c}_u_um")), fmt(row.get(f"{c}_v_um"))]
        rows.append(cells)
    return Table(
        "Table 4-style: temperatures at each run's first and last visit and each camera's "
        "drift at its last visit (anchored at its first)",
        cols,
        rows,
    )


def _paper_table4() -> Table:
    """The paper's Table 4, as printed."""
    pd_ = load_paper_data()
    rows = [
        [
            f"Run {r.run}",
            fmt(r.speed_pct, 0),
            fmt(r.start_c[0]),
            fmt(r.end_c[0]),
            fmt(r.delta_c[0]),
            fmt(r.start_c[1]),
            fmt(r.end_c[1]),
            fmt(r.delta_c[1]),
            *[fmt(r.dl_um.get(c), 0) for c in pd_.cameras],
        ]
        for r in pd_.runs.values()
    ]
    return Table(
        "The paper's Table 4, as printed (drift along the cameras' y axes)",
        [
            "run",
            "speed (%)",
            "link2 start (°C)",
            "link2 end (°C)",
            "ΔT₂ (K)",
            "link3 start (°C)",
            "link3 end (°C)",
            "ΔT₃ (K)",
            *[f"Δl {c} (µm)" for c in pd_.cameras],
        ],
        rows,
    )


def _interval(v: Mapping[str, Any]) -> str:
    return f"{fmt_alpha(v['ci95'][0])} – {fmt_alpha(v['ci95'][1])}"


def _table6(d: ReportData, fit: Mapping[str, Any]) -> Table:
    """Table 6-style: α on the training runs, time series and the paper's start/end."""
    a = fit["alpha_per_k"]
    series = ["time-series", join(d.train), "all", "u and v", fmt_alpha(a["value"]), _interval(a)]
    rows = [[*series, fmt(fit["rms_um"], 3)]]
    for run, se in fit.get("start_end", {}).items():
        axes = {c: v.get("axis") or "" for c, v in se["per_camera"].items()}
        for cam, v in [*se["per_camera"].items(), ("mean", se["mean"])]:
            ax = axes.get(cam) or " and ".join(sorted({x for x in axes.values() if x}))
            rows.append(["start/end", run, cam, ax, fmt_alpha(v["value"]), _interval(v), ""])
    return Table(
        "Table 6-style: α (×10⁻⁶/K) fitted on the training run(s), time-series least squares "
        "(every visit, both chip axes) and the paper's start/end estimator (per camera along "
        "the chip axis given: the one along which the model predicts the larger drift; the "
        "mean of the cameras'), as `thermrs fit --json` gives them",
        ["estimator", "run", "camera", "chip axis", "α (×10⁻⁶/K)", "95 % interval", "rms (µm)"],
        rows,
    )


def _table7(d: ReportData) -> Table | Missing:
    """Table 7-style: predicted against measured drift at the end of the runs, per α."""
    if d.prediction is None:
        return Missing(d.fit_note or "Nothing was predicted.")
    rows = [
        [
            r["alpha"],
            fmt_alpha(r["alpha_per_k"]),
            r["camera"],
            r["run"],
            r["axis"],
            fmt(r["predicted_um"]),
            fmt(r["measured_um"]),
            end_error(r["predicted_um"], r["measured_um"], r["noise_um"], suffix=""),
            fmt(r["rms_centred_um"], 3),
            fmt(r["noise_um"], 3),
        ]
        for r in d.prediction.iter_rows(named=True)
    ]
    what = (
        "the training run itself (one run only: nothing held out)"
        if d.prediction_in_sample
        else "the held-out runs"
    )
    return Table(
        f"Table 7-style: predicted against measured drift at the end of {what}, per α "
        "(series: time-series fit; per camera and mean: start/end, fitted along the chip axis "
        "Table 6 gives), compared along the chip axis given (the end drift is one axis's: an α "
        "fitted along one axis and compared along the other can be far off), as `thermrs "
        "predict --json` gives them; rms: over every visit, both axes, mean offset removed; "
        "noise: the measurement's own (von Neumann)",
        [
            "α",
            "α (×10⁻⁶/K)",
            "camera",
            "run",
            "chip axis",
            "predicted (µm)",
            "measured (µm)",
            "error (% or µm where the drift is within noise)",
            "rms (µm)",
            "noise (µm)",
        ],
        rows,
    )
