"""The report as a document: sections of paragraphs, tables, figures and notes, composed from
:class:`thermrs.report.data.ReportData`. Rendering (HTML, Markdown) is in
:mod:`thermrs.report.render`.

Numbers are printed with fixed precision, the same everywhere: α in 10⁻⁶/K with three
decimals, drift and RP in µm with two (residual RMS and noise with three), temperatures in °C
with two, τ in minutes with one, shares in per cent with one.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import polars as pl

from thermrs.numbers import (
    end_error,
    fmt,
    fmt_alpha,
    gap_closed,
    implausible,
    tau_determined,
    within_noise,
)
from thermrs.report import figures as F
from thermrs.report.data import (
    ISO_TOLERANCE_UM,
    ISO_WINDOW,
    ReportData,
    diagnosis_json,
    diagnosis_residuals,
)

__all__ = ["Figure", "Missing", "Paragraph", "Section", "Table", "compose", "fmt"]


@dataclass(frozen=True)
class Paragraph:
    """Plain text (escaped when rendered)."""

    text: str


@dataclass(frozen=True)
class Missing:
    """What a section cannot show, and why (never silently left out)."""

    text: str


@dataclass(frozen=True)
class Table:
    """A table of formatted cells."""

    caption: str
    columns: list[str]
    rows: list[list[str]]


@dataclass(frozen=True)
class Figure:
    """An SVG figure."""

    name: str
    caption: str
    svg: str


Block = Paragraph | Missing | Table | Figure


@dataclass
class Section:
    """A titled section; ``id`` anchors it (``#rig``, ``#diagnosis``, …)."""

    id: str
    title: str
    blocks: list[Block] = field(default_factory=list)
    subsections: list[Section] = field(default_factory=list)


#: Every top-level section, in order (the test checks they are all there).
SECTION_IDS = (
    "summary",
    "rig",
    "runs",
    "heating",
    "tables",
    "prediction",
    "iso9283",
    "diagnosis",
    "extraction",
)


def _axis_name(axis: str) -> str:
    return f"{'x' if axis == 'u' else 'y'} ({axis})"


def _join(items: Sequence[str]) -> str:
    items = list(items)
    if len(items) <= 1:
        return "".join(items)
    return ", ".join(items[:-1]) + " and " + items[-1]


# --- summary -------------------------------------------------------------------------------


def _tcol(d: ReportData) -> dict[str, str]:
    """One colour per temperature series throughout the report."""
    return F.temperature_colours(sorted({n for r in d.runs for n in r.roi_names}))


def _summary(d: ReportData, colours: Mapping[str, str]) -> Section:
    s = Section("summary", "Summary")
    rig = d.rig
    n = len(d.runs)
    hours = sum(float(r["hours"]) for r in d.table4.iter_rows(named=True))
    s.blocks.append(
        Paragraph(
            f"This report covers {n} run{'s' if n != 1 else ''} "
            f"({_join([r.name for r in d.runs])}), {fmt(hours, 1)} h in all, "
            f"recorded on a {rig.model} with camera"
            f"{'s' if len(rig.cameras) != 1 else ''} {_join([c.name for c in rig.cameras])}."
        )
    )
    mapped = [n for n in d.rig.mapped_temperatures if any(n in r.roi_names for r in d.runs)]
    s.blocks.append(
        Figure(
            "overview",
            "At a glance: every run on one time axis; each camera's drift along chip x (u, "
            "solid) and y (v, dotted), anchored at each run's first visit, and the temperatures "
            "the model expands the links with.",
            F.fig_overview([(r.name, r.table) for r in d.runs], colours, mapped, _tcol(d)),
        )
    )
    for row in d.table4.iter_rows(named=True):
        run = d.run(row["run"])
        temps = [
            f"{name} went from {fmt(row.get(f'{name}_start_c'))} to "
            f"{fmt(row.get(f'{name}_end_c'))} °C"
            for name in run.roi_names
            if name != "ambient" and f"{name}_start_c" in row
        ]
        best = None
        for cam in [c.name for c in rig.cameras]:
            for ax in "uv":
                v = row.get(f"{cam}_{ax}_um")
                if v is not None and math.isfinite(v) and (best is None or abs(v) > abs(best[2])):
                    best = (cam, ax, v)
        drift = (
            f"the largest drift by its last visit was camera {best[0]}'s {fmt(best[2])} µm along "
            f"the chip's {_axis_name(best[1])} axis"
            if best
            else "no camera drift could be measured"
        )
        during = f"; meanwhile {_join(temps)}" if temps else " (no thermal readings)"
        s.blocks.append(Paragraph(f"In {row['run']} ({fmt(row['hours'], 1)} h), {drift}{during}."))
    if d.fit is not None:
        a = d.fit["alpha_per_k"]
        s.blocks.append(
            Paragraph(
                f"Fitted on {_join(d.train)}, the nominal model's expansion coefficient is "
                f"α = {fmt_alpha(a['value'])} ×10⁻⁶/K (95 % interval "
                f"{fmt_alpha(a['ci95'][0])} – {fmt_alpha(a['ci95'][1])}), leaving an RMS residual "
                f"of {fmt(d.fit['rms_um'], 3)} µm over {d.fit['n_visits']} visits."
            )
        )
    else:
        s.blocks.append(Missing(d.fit_note or "α was not fitted."))
    if d.prediction is not None and d.prediction.height:
        p = d.prediction.filter(pl.col("alpha") == "series")
        quiet = [within_noise(m, n) for m, n in zip(p["measured_um"], p["noise_um"], strict=True)]
        errs = [e for e, q in zip(p["error_pct"], quiet, strict=True) if not q]
        which = (
            "the training run itself (no run was held out)"
            if d.prediction_in_sample
            else (f"the held-out run{'s' if len(d.holdout) > 1 else ''} {_join(d.holdout)}")
        )
        s.blocks.append(
            Paragraph(
                f"With that α the forward model's prediction of {which} is off by "
                + (
                    f"{fmt(min(errs), 2, sign=True)} to {fmt(max(errs), 2, sign=True)} % at the "
                    "run's end (predicted − measured, per camera and run"
                    if errs
                    else "an end drift inside the noise wherever it is measured (no % error is "
                    "meaningful there"
                )
                + (
                    f"; {sum(quiet)} end drift(s) within the noise, compared in µm in Table 7)"
                    if errs and any(quiet)
                    else ")"
                )
                + "; over every visit the "
                "RMS difference "
                f"(mean offset removed) is {fmt(min(p['rms_centred_um']), 3)} – "
                f"{fmt(max(p['rms_centred_um']), 3)} µm against a measurement noise of "
                f"{fmt(min(p['noise_um']), 3)} – {fmt(max(p['noise_um']), 3)} µm."
            )
        )
    if d.diagnosis is not None:
        doc = diagnosis_json(d.diagnosis)
        if doc.get("summary"):
            s.blocks.append(Paragraph(str(doc["summary"])))
    elif d.diagnosis_note:
        s.blocks.append(Paragraph(d.diagnosis_note))
    skipped = sum(sum(r.extract_report.skipped.values()) for r in d.runs if r.extract_report)
    lost = [r.name for r in d.runs if r.data_loss]
    if lost:
        s.blocks.append(
            Paragraph(
                f"Part of the recording of {_join(lost)} was lost (see the extraction section)."
            )
        )
    elif any(r.extract_report for r in d.runs):
        s.blocks.append(
            Paragraph(
                "Extraction lost nothing"
                + (
                    f" and skipped {skipped:,} messages (see why below)."
                    if skipped
                    else " and skipped no message."
                )
            )
        )
    return s


# --- rig -----------------------------------------------------------------------------------


def _rig(d: ReportData, colours: Mapping[str, str]) -> Section:
    r = d.rig
    s = Section("rig", "The rig")
    s.blocks.append(
        Paragraph(
            f"{r.name or r.model} ({Path(r.source).name}): robot {r.model}, joint states on "
            f"{r.joint_states_topic}; camera{'s' if len(r.cameras) != 1 else ''} "
            + _join([f"{c.name} at pose {c.pose} ({c.topic})" for c in r.cameras])
            + "; "
            + (
                f"thermal camera on {r.thermal_topic} with ROIs {_join([x.name for x in r.rois])}"
                if r.thermal_topic
                else "no thermal camera"
            )
            + f"; nominal α = {fmt_alpha(r.alpha_per_k)} ×10⁻⁶/K at {fmt(r.reference_c, 1)} °C, "
            "expanding " + _join([f"{m.name} with {m.temperature}" for m in r.lengths]) + "."
        )
    )
    rows = []
    for pose, p in d.rig_view["poses"].items():
        for cam, spot in p["spot_px"].items():
            own = r.camera(cam).pose == pose
            rows.append(
                [
                    pose,
                    ", ".join(fmt(v) for v in p["flange_mm"]),
                    fmt(p.get("elevation_deg")),
                    fmt(p.get("azimuth_deg")),
                    cam + (" (its pose)" if own else ""),
                    "misses" if spot is None else f"{fmt(spot[0], 3)}, {fmt(spot[1], 3)}",
                    fmt(p["incidence_deg"].get(cam), 4),
                    fmt(p.get("distance_mm", {}).get(cam), 3),
                ]
            )
    s.blocks.append(
        Table(
            "Poses: flange position, and where the laser meets each chip at nominal lengths",
            [
                "pose",
                "flange x, y, z (mm)",
                "elevation (°)",
                "azimuth (°)",
                "camera",
                "spot x, y (px)",
                "incidence (°)",
                "distance (mm)",
            ],
            rows,
        )
    )
    s.blocks.append(
        Figure(
            "rig",
            "Where the laser meets each camera's chip at the camera's own pose (nominal lengths).",
            F.fig_rig(
                d.rig_view,
                {c.name: (int(c.size_px[0]), int(c.size_px[1])) for c in r.cameras},
                {c.name: c.pose for c in r.cameras},
                colours,
            ),
        )
    )
    return s


# --- runs ----------------------------------------------------------------------------------


def _runs(d: ReportData, colours: Mapping[str, str]) -> Section:
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
                F.fig_run(run.table, curves, colours, _tcol(d), temperatures=run.temperatures),
            )
        )
        s.subsections.append(sub)
    return s


# --- heating curves ------------------------------------------------------------------------


def _heating(d: ReportData) -> Section:
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
            series, unit = f"drift camera {row['camera']} {_axis_name(row['axis'])} (µm)", "µm"
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


# --- tables 4, 6, 7 -------------------------------------------------------------------------


def _tables(d: ReportData) -> Section:
    s = Section("tables", "Tables 4, 6 and 7")
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
    s.blocks.append(
        Table(
            "Table 4-style: temperatures at each run's first and last visit and each camera's "
            "drift at its last visit (anchored at its first)",
            cols,
            rows,
        )
    )
    if d.paper_reference:
        from thermrs.paper import load_paper_data

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
        s.blocks.append(
            Table(
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
        )
    if d.fit is None:
        s.blocks.append(Missing(d.fit_note or "α was not fitted: no Table 6 or 7."))
        return s
    a = d.fit["alpha_per_k"]
    rows = [
        [
            "time-series",
            _join(d.train),
            "all",
            fmt_alpha(a["value"]),
            f"{fmt_alpha(a['ci95'][0])} – {fmt_alpha(a['ci95'][1])}",
            fmt(d.fit["rms_um"], 3),
        ]
    ]
    for run, se in d.fit.get("start_end", {}).items():
        items = [*se["per_camera"].items(), ("mean", se["mean"])]
        for cam, v in items:
            rows.append(
                [
                    "start/end",
                    run,
                    cam,
                    fmt_alpha(v["value"]),
                    f"{fmt_alpha(v['ci95'][0])} – {fmt_alpha(v['ci95'][1])}",
                    "",
                ]
            )
    s.blocks.append(
        Table(
            "Table 6-style: α (×10⁻⁶/K) fitted on the training run(s), time-series least squares "
            "and the paper's start/end estimator (as `thermrs fit --json` gives them)",
            ["estimator", "run", "camera", "α (×10⁻⁶/K)", "95 % interval", "rms (µm)"],
            rows,
        )
    )
    s.blocks.append(_table7(d))
    return s


def _table7(d: ReportData) -> Table | Missing:
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
        "(series: time-series fit; per camera and mean: start/end), as `thermrs predict --json` "
        "gives them; rms: over every visit, both axes, mean offset removed; noise: the "
        "measurement's own (von Neumann)",
        [
            "α",
            "α (×10⁻⁶/K)",
            "camera",
            "run",
            "axis",
            "predicted (µm)",
            "measured (µm)",
            "error (% or µm within noise)",
            "rms (µm)",
            "noise (µm)",
        ],
        rows,
    )


# --- prediction ----------------------------------------------------------------------------


def _prediction(d: ReportData, colours: Mapping[str, str]) -> Section:
    s = Section("prediction", "Prediction against measurement")
    if d.series is None or d.fit is None:
        s.blocks.append(Missing(d.fit_note or "Nothing was predicted."))
        return s
    a = d.fit["alpha_per_k"]["value"]
    if d.prediction_in_sample:
        s.blocks.append(
            Missing(
                f"One run only: nothing was held out, so the prediction below is of "
                f"{_join(d.train)} itself with the α fitted on it (an in-sample check, not a "
                "prediction). Give more runs to predict runs kept out of the fit."
            )
        )
    else:
        s.blocks.append(
            Paragraph(
                f"Every visit of the held-out run{'s' if len(d.holdout) > 1 else ''} "
                f"{_join(d.holdout)} predicted from its own temperatures with the forward "
                f"model and α = {fmt_alpha(a)} ×10⁻⁶/K fitted on {_join(d.train)}; below, "
                "measured − predicted."
            )
        )
    for run in d.holdout or d.train:
        s.blocks.append(
            Figure(
                f"prediction-{run}",
                f"{run}: predicted (dashed) against measured (thin line) drift along chip x (u) "
                "and y (v), and the residual (measured − predicted).",
                F.fig_prediction(d.series, colours, run),
            )
        )
    return s


# --- ISO 9283 ------------------------------------------------------------------------------


def _iso(d: ReportData, colours: Mapping[str, str]) -> Section:
    from thermrs.iso9283 import LABEL

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
                F.fig_iso(d.iso_windows, colours),
            )
        )
    else:
        s.blocks.append(Missing(f"No run has a window of {ISO_WINDOW} visits: no figure."))
    return s


# --- diagnosis -----------------------------------------------------------------------------


def _params(p: Mapping[str, Any] | None) -> str:
    if not p:
        return ""
    out = []
    for k, v in p.items():
        if isinstance(v, float):
            out.append(f"{k} = {v:.4g}")
        elif isinstance(v, list | tuple):
            out.append(
                f"{k} = ["
                + ", ".join(f"{x:.4g}" if isinstance(x, float) else str(x) for x in v)
                + "]"
            )
        elif isinstance(v, Mapping):
            out.append(
                f"{k} = {{"
                + ", ".join(
                    f"{kk}: {vv:.4g}" if isinstance(vv, float) else f"{kk}: {vv}"
                    for kk, vv in v.items()
                )
                + "}"
            )
        else:
            out.append(f"{k} = {v}")
    return "; ".join(out)


def _yes_no(x: object) -> str:
    return "yes" if x is True else "no" if x is False else "—"


def _diagnosis(d: ReportData, colours: Mapping[str, str]) -> Section:
    s = Section("diagnosis", "Diagnosis")
    if d.diagnosis is None:
        s.blocks.append(Missing(d.diagnosis_note or "No diagnosis was made."))
        return s
    doc = diagnosis_json(d.diagnosis)
    if doc.get("summary"):
        s.blocks.append(Paragraph(str(doc["summary"])))
    v = doc.get("verdict") or {}
    b = doc.get("baseline") or {}
    hf = doc.get("how_far") or {}
    status = v.get("status", "none")
    # Said once: the effect is named here only where the reason does not name it already.
    reason = str(v.get("reason", ""))
    what = ""
    if status == "identified" and v.get("effect"):
        params = f" ({_params(v.get('params'))})" if v.get("params") else ""
        what = (f" {v['effect']}" if str(v["effect"]) not in reason else "") + params
    s.blocks.append(Paragraph(f"Verdict — {status}{what}: {reason}".strip()))
    floor = doc.get("noise_floor") or {}
    parts = floor.get("parts") or {}
    if parts:
        cmax = floor.get("correlation_time_max_min")
        s.blocks.append(
            Table(
                "The noise floor, part by part (what is noise by physics; anything slower than "
                f"{fmt(cmax, 1)} min, a tenth of the shortest thermal time constant, is gap)",
                ["part", "µm", "how it was estimated"],
                [
                    ["centroid (frames within a visit)", fmt(parts.get("centroid_um"), 3),
                     str(parts.get("centroid", ""))],
                    ["visit repeatability, white", fmt(parts.get("visit_white_um"), 3),
                     str(parts.get("visit_white", ""))],
                    ["pose error correlated over "
                     f"{fmt(parts.get('pose_correlation_time_min'), 1)} min",
                     fmt(parts.get("pose_correlated_um"), 3),
                     str(parts.get("pose_correlated", ""))],
                    ["joint states", fmt(parts.get("joints_um"), 3), str(parts.get("joints", ""))],
                    *[[f"floor of run {r}", fmt(x, 3), "the run's series pooled"]
                      for r, x in (floor.get("per_run_um") or {}).items()],
                    ["thermal time constants (min)",
                     ", ".join(f"{k} {fmt(x, 0)}" for k, x in
                               (floor.get("thermal_time_constants_min") or {}).items()),
                     str(floor.get("thermal_time_constants", ""))],
                ],
            )
        )  # fmt: skip
    alpha = b.get("alpha_per_k") or {}
    rows = [
        ["noise floor (visit to visit)", fmt(doc.get("noise_floor_um"), 3), ""],
        [
            "baseline α (×10⁻⁶/K)",
            fmt_alpha(alpha.get("value")),
            " – ".join(fmt_alpha(x) for x in alpha.get("ci95", [])) or "",
        ],
        ["training RMS, nominal model", fmt(b.get("train_rms_um"), 3), ""],
        [
            "held-out RMS, nominal model",
            fmt(b.get("holdout_rms_um"), 3),
            f"max {fmt(b.get('holdout_max_um'), 3)}",
        ],
        [
            "held-out RMS, with the chosen effect",
            fmt(hf.get("holdout_rms_after_um"), 3),
            f"max {fmt(hf.get('holdout_max_after_um'), 3)}",
        ],
        [
            "share of the gap closed",
            gap_closed(
                hf.get("gap_closed_raw", hf.get("gap_closed")),
                hf.get("holdout_rms_after_um"),
                doc.get("noise_floor_um"),
            ),
            "",
        ],
    ]
    s.blocks.append(
        Table("How far: the nominal model and the chosen effect (µm)", ["", "value", ""], rows)
    )
    if d.diagnosed_prediction is not None:
        s.blocks.append(
            Table(
                "The held-out runs predicted with α and the identified effect (`thermrs predict "
                "--diagnosis`): RMS of measured − predicted over every visit, both axes, each "
                "series' mean removed (µm)",
                ["run", "camera", "nominal model", "with the effect", "shrink (%)", "visits"],
                [
                    [r["run"], r["camera"], fmt(r["nominal_rms_um"], 3),
                     fmt(r["diagnosed_rms_um"], 3), fmt(100 * r["shrink"], 1),
                     str(r["n_visits"])]
                    for r in d.diagnosed_prediction.iter_rows(named=True)
                ],
            )
        )  # fmt: skip
    loc = sorted(doc.get("location") or [], key=lambda r: -float(r.get("share") or 0))
    if loc:
        s.blocks.append(
            Table(
                "Where: the nominal model's residual by run, camera, axis and phase (largest "
                "share first)",
                ["run", "camera", "axis", "phase", "rms (µm)", "share (%)", "visits"],
                [
                    [
                        r["run"],
                        r["camera"],
                        r["axis"],
                        r.get("phase", ""),
                        fmt(r["rms_um"], 3),
                        fmt(100 * float(r["share"]), 1),
                        str(r.get("n", "")),
                    ]
                    for r in loc[:12]
                ],
            )
        )
    drivers = doc.get("drivers") or []
    if drivers:
        s.blocks.append(
            Table(
                "What the residual follows: correlation with temperatures, rates, ambient, time",
                ["driver", "chip axis", "correlation", "p"],
                [
                    [
                        r["driver"],
                        _axis_name(r["axis"]) if r.get("axis") else "—",
                        fmt(r["corr"], 3),
                        f"{float(r['p']):.2g}",
                    ]
                    for r in drivers
                ],
            )
        )
    w = doc.get("whiteness")
    if w:
        s.blocks.append(
            Paragraph(
                f"Whiteness of the nominal residual: Ljung–Box p = {float(w['ljung_box_p']):.2g}, "
                f"lag-1 autocorrelation {fmt(w['rho1'], 3)}, {fmt(w['n_eff'], 0)} effective "
                f"samples: {'white (noise)' if w.get('white') else 'structured (not noise)'}."
            )
        )
    ranking = doc.get("ranking") or []
    if ranking:
        s.blocks.append(
            Table(
                "Which: every effect of the library fitted on the training runs, judged on the "
                "held-out runs (shrink = 1 − held-out RMS with it / nominal)",
                [
                    "effect",
                    "parameters",
                    "train RMS (µm)",
                    "held-out RMS (µm)",
                    "shrink",
                    "ΔAICc",
                    "placebo beaten",
                    "plausible",
                ],
                [
                    [
                        r["effect"],
                        _params(r.get("params")),
                        fmt(r.get("train_rms_um"), 3),
                        fmt(r.get("holdout_rms_um"), 3),
                        fmt(r.get("shrink"), 3),
                        fmt((r.get("evidence") or {}).get("delta_aicc"), 1),
                        _yes_no((r.get("evidence") or {}).get("placebo_beaten")),
                        implausible(r["effect"], r.get("params") or {})
                        or _yes_no((r.get("evidence") or {}).get("plausible")),
                    ]
                    for r in ranking
                ],
            )
        )
    conf = doc.get("confounded") or []
    if conf:
        s.blocks.append(
            Table(
                "Confounded candidates: how alike their signatures are on these runs, and where "
                "the runs tell them apart best",
                ["effects", "similarity (cos)", "on these runs"],
                [
                    [" / ".join(c["effects"]), fmt(c.get("cos"), 3), c.get("separate_by", "")]
                    for c in conf
                ],
            )
        )
    else:
        s.blocks.append(Paragraph("No two candidate effects were confounded."))
    res = diagnosis_residuals(d.diagnosis)
    if res is not None and res.height:
        s.blocks.append(
            Figure(
                "diagnosis",
                "Residuals of the held-out runs: nominal model (faint) and with the chosen "
                "effect (bold), per camera and chip axis.",
                F.fig_diagnosis(res, colours),
            )
        )
    else:
        s.blocks.append(Missing("The diagnosis carries no per-visit residuals: no figure."))
    if d.design_section is not None:
        s.subsections.append(d.design_section)
    elif d.design_note:
        s.blocks.append(Missing(d.design_note))
    return s


# --- extraction ----------------------------------------------------------------------------


def _extraction(d: ReportData) -> Section:
    s = Section("extraction", "What extraction skipped and why")
    # Runs cut from one recording share its extraction: shown once.
    groups: dict[object, list[Any]] = {}
    for run in d.runs:
        key = id(run.extract_report) if run.extract_report is not None else run.name
        groups.setdefault(key, []).append(run)
    for runs in groups.values():
        first = runs[0]
        rep = first.extract_report
        if len(runs) > 1:
            title = f"{_join([r.name for r in runs])} (cut from {first.recording})"
        else:
            title = f"{first.name} ({first.source})"
        sub = Section(f"extraction-{first.name}", title)
        rows = []
        for r in runs:
            if r.frames_by_status is None:
                continue
            total = sum(r.frames_by_status.values())
            rows += [
                [r.name, k, f"{v:,}", fmt(100 * v / total if total else None, 1)]
                for k, v in r.frames_by_status.items()
            ]
        if rows:
            sub.blocks.append(
                Table("CCD frames by status", ["run", "status", "frames", "share (%)"], rows)
            )
        for r in runs:
            if r.frames_by_status is None:
                sub.blocks.append(
                    Missing(
                        f"{r.name}: no frames table beside the run's tables: frame counts by "
                        "status are not available."
                    )
                )
            if r.joints == 0:
                sub.blocks.append(
                    Missing(
                        f"{r.name}: no joint states, so every spot frame counted as at its "
                        "camera's pose (visits could not be checked against the joints)."
                    )
                )
            elif r.joints is None:
                sub.blocks.append(Missing(f"{r.name}: no joints table beside the run's tables."))
        known = [r for r in runs if r.joints]
        if known:
            sub.blocks.append(
                Paragraph(
                    "Joint states read: " + ", ".join(f"{r.name} {r.joints:,}" for r in known) + "."
                )
            )
        if rep is None:
            sub.blocks.append(
                Missing(
                    "Given as extracted tables: the extraction's report (skipped messages and "
                    "why, losses) is not stored beside them. Give the recording to see it."
                )
            )
        else:
            msg = ", ".join(f"{k}: {v:,}" for k, v in sorted(rep.messages.items()))
            sub.blocks.append(
                Paragraph(
                    f"Read {rep.file_bytes / 1e6:,.1f} MB in {rep.chunks:,} chunks"
                    f"{' using the summary' if rep.used_summary else ' without a summary'}; "
                    f"messages per topic: {msg or 'none'}; other topics: {rep.other_messages:,}."
                )
            )
            if rep.skipped:
                sub.blocks.append(
                    Table(
                        "Skipped messages",
                        ["topic: reason (first seen)", "count"],
                        [
                            [rep.skipped_examples.get(k, k), f"{v:,}"]
                            for k, v in rep.skipped.items()
                        ],
                    )
                )
            else:
                sub.blocks.append(Paragraph("No message was skipped."))
            for loss in rep.losses:
                sub.blocks.append(Missing(f"Data loss: {loss.get('detail', loss)}"))
            if rep.recovered_messages:
                sub.blocks.append(
                    Paragraph(
                        f"{rep.recovered_messages:,} complete messages recovered from a cut chunk."
                    )
                )
        s.subsections.append(sub)
    return s


def compose(d: ReportData) -> list[Section]:
    """Every section of the report, in order (:data:`SECTION_IDS`)."""
    colours = F.camera_colours([c.name for c in d.rig.cameras])
    sections = [
        _summary(d, colours),
        _rig(d, colours),
        _runs(d, colours),
        _heating(d),
        _tables(d),
        _prediction(d, colours),
        _iso(d, colours),
        _diagnosis(d, colours),
        _extraction(d),
    ]
    assert tuple(x.id for x in sections) == SECTION_IDS
    return sections
