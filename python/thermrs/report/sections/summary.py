"""The summary: what was recorded, the largest drift per run, α, how well it predicts, the
diagnosis in one sentence and what extraction lost.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import polars as pl

from thermrs.numbers import fmt, fmt_alpha, within_noise
from thermrs.report.blocks import Block, Figure, Missing, Paragraph, Section
from thermrs.report.data import ReportData, diagnosis_json
from thermrs.report.figures import fig_overview
from thermrs.report.sections.common import axis_name, join, series_colours

__all__ = ["section"]


def section(d: ReportData, colours: Mapping[str, str]) -> Section:
    """The summary section: the runs, their drift, α, the prediction, the diagnosis, losses."""
    s = Section("summary", "Summary")
    s.blocks += _overview(d, colours)
    s.blocks += [_run_paragraph(d, row) for row in d.table4.iter_rows(named=True)]
    s.blocks.append(_fit(d))
    if d.prediction is not None and d.prediction.height:
        s.blocks.append(_prediction(d, d.prediction))
    s.blocks += _diagnosis(d)
    s.blocks += _extraction(d)
    return s


def _overview(d: ReportData, colours: Mapping[str, str]) -> list[Block]:
    """What was recorded, and every run on one time axis."""
    rig = d.rig
    n = len(d.runs)
    hours = sum(float(r["hours"]) for r in d.table4.iter_rows(named=True))
    mapped = [n for n in d.rig.mapped_temperatures if any(n in r.roi_names for r in d.runs)]
    return [
        Paragraph(
            f"This report covers {n} run{'s' if n != 1 else ''} "
            f"({join([r.name for r in d.runs])}), {fmt(hours, 1)} h in all, "
            f"recorded on a {rig.model} with camera"
            f"{'s' if len(rig.cameras) != 1 else ''} {join([c.name for c in rig.cameras])}."
        ),
        Figure(
            "overview",
            "At a glance: every run on one time axis; each camera's drift along chip x (u, "
            "solid) and y (v, dotted), anchored at each run's first visit, and the temperatures "
            "the model expands the links with.",
            fig_overview([(r.name, r.table) for r in d.runs], colours, mapped, series_colours(d)),
        ),
    ]


def _largest_drift(row: Mapping[str, Any], cameras: list[str]) -> tuple[str, str, float] | None:
    """(camera, axis, µm) of the largest drift by a run's last visit (Table 4 row), or None."""
    best = None
    for cam in cameras:
        for ax in "uv":
            v = row.get(f"{cam}_{ax}_um")
            if v is not None and math.isfinite(v) and (best is None or abs(v) > abs(best[2])):
                best = (cam, ax, v)
    return best


def _run_paragraph(d: ReportData, row: Mapping[str, Any]) -> Paragraph:
    """One run: its largest drift and how its temperatures went."""
    run = d.run(row["run"])
    temps = [
        f"{name} went from {fmt(row.get(f'{name}_start_c'))} to {fmt(row.get(f'{name}_end_c'))} °C"
        for name in run.roi_names
        if name != "ambient" and f"{name}_start_c" in row
    ]
    best = _largest_drift(row, [c.name for c in d.rig.cameras])
    drift = (
        f"the largest drift by its last visit was camera {best[0]}'s {fmt(best[2])} µm along "
        f"the chip's {axis_name(best[1])} axis"
        if best
        else "no camera drift could be measured"
    )
    during = f"; meanwhile {join(temps)}" if temps else " (no thermal readings)"
    return Paragraph(f"In {row['run']} ({fmt(row['hours'], 1)} h), {drift}{during}.")


def _fit(d: ReportData) -> Paragraph | Missing:
    """α of the nominal model, or why it was not fitted."""
    if d.fit is None:
        return Missing(d.fit_note or "α was not fitted.")
    a = d.fit["alpha_per_k"]
    return Paragraph(
        f"Fitted on {join(d.train)}, the nominal model's expansion coefficient is "
        f"α = {fmt_alpha(a['value'])} ×10⁻⁶/K (95 % interval "
        f"{fmt_alpha(a['ci95'][0])} – {fmt_alpha(a['ci95'][1])}), leaving an RMS residual "
        f"of {fmt(d.fit['rms_um'], 3)} µm over {d.fit['n_visits']} visits."
    )


def _prediction(d: ReportData, prediction: pl.DataFrame) -> Paragraph:
    """How far off the prediction with that α is, at the runs' ends along each chip axis
    compared, and over every visit."""
    p = prediction.filter(pl.col("alpha") == "series")
    quiet = [within_noise(m, n) for m, n in zip(p["measured_um"], p["noise_um"], strict=True)]
    which = (
        "the training run itself (no run was held out)"
        if d.prediction_in_sample
        else (f"the held-out run{'s' if len(d.holdout) > 1 else ''} {join(d.holdout)}")
    )
    per_axis = []
    for ax in sorted(set(p["axis"].to_list()), reverse=True):  # v (the paper's) first
        errs = [
            e for e, a, q in zip(p["error_pct"], p["axis"], quiet, strict=True) if a == ax and not q
        ]
        per_axis.append(
            f"{fmt(min(errs), 2, sign=True)} to {fmt(max(errs), 2, sign=True)} % along the "
            f"chip's {axis_name(ax)} axis"
            if errs
            else f"an end drift inside the noise along the chip's {axis_name(ax)} axis"
        )
    return Paragraph(
        f"With that α the forward model's prediction of {which} is off at the run's end "
        f"(predicted − measured, per camera and run) by {join(per_axis)}"
        + (
            f" ({sum(quiet)} end drift(s) within the noise, compared in µm in Table 7)"
            if any(quiet)
            else ""
        )
        + "; over every visit the "
        "RMS difference "
        f"(mean offset removed) is {fmt(min(p['rms_centred_um']), 3)} – "
        f"{fmt(max(p['rms_centred_um']), 3)} µm against a measurement noise of "
        f"{fmt(min(p['noise_um']), 3)} – {fmt(max(p['noise_um']), 3)} µm."
    )


def _diagnosis(d: ReportData) -> list[Block]:
    """The diagnosis' own summary (or why there is none), and what it was made without."""
    from thermrs.report.sections.diagnosis import excluded

    out: list[Block] = []
    if d.diagnosis is not None:
        doc = diagnosis_json(d.diagnosis)
        out += [Paragraph(str(doc["summary"]))] if doc.get("summary") else []
    elif d.diagnosis_note:
        out.append(Paragraph(d.diagnosis_note))
    ex = excluded(d)
    return out + ([ex] if ex is not None else [])


def _extraction(d: ReportData) -> list[Block]:
    """What extraction lost or skipped, in one sentence."""
    skipped = sum(sum(r.extract_report.skipped.values()) for r in d.runs if r.extract_report)
    lost = [r.name for r in d.runs if r.data_loss]
    if lost:
        return [
            Paragraph(
                f"Part of the recording of {join(lost)} was lost (see the extraction section)."
            )
        ]
    if any(r.extract_report for r in d.runs):
        return [
            Paragraph(
                "Extraction lost nothing"
                + (
                    f" and skipped {skipped:,} messages (see why below)."
                    if skipped
                    else " and skipped no message."
                )
            )
        ]
    return []
