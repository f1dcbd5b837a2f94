"""The diagnosis: verdict, noise floor, how far the nominal model and the chosen effect get, where
and what the residual follows, the ranking of effects, confounded pairs, and the experiment that
settles an ambiguous one (:mod:`thermrs.report.sections.design`).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import polars as pl

from thermrs.numbers import fmt, fmt_alpha, gap_closed, implausible
from thermrs.report.blocks import Block, Figure, Missing, Paragraph, Section, Table
from thermrs.report.data import ReportData, diagnosis_json, diagnosis_residuals
from thermrs.report.figures import fig_diagnosis
from thermrs.report.sections.common import axis_name

__all__ = ["excluded", "section"]

Doc = Mapping[str, Any]


def section(d: ReportData, colours: Mapping[str, str]) -> Section:
    """The diagnosis section (or why there is none), with the design as a subsection."""
    s = Section("diagnosis", "Diagnosis")
    if d.diagnosis is None:
        s.blocks.append(Missing(d.diagnosis_note or "No diagnosis was made."))
        return s
    doc = diagnosis_json(d.diagnosis)
    if doc.get("summary"):
        s.blocks.append(Paragraph(str(doc["summary"])))
    s.blocks.append(_verdict(doc))
    s.blocks.append(excluded(d) or Paragraph(NOTHING_EXCLUDED))
    s.blocks += _noise_floor(doc)
    s.blocks.append(_how_far(doc))
    if d.diagnosed_prediction is not None:
        s.blocks.append(_diagnosed_prediction(d.diagnosed_prediction))
    s.blocks += _where(doc)
    s.blocks += _drivers(doc)
    s.blocks += _whiteness(doc)
    s.blocks += _ranking(doc)
    s.blocks.append(_confounded(doc))
    s.blocks.append(_residual_figure(d, colours))
    if d.baselines is not None:
        from thermrs.report.sections.baselines import subsection

        s.subsections.append(subsection(d.baselines))
    if d.design is not None:
        from thermrs.report.sections.design import design_section

        s.subsections.append(design_section(d.design.to_json(), d.design_drift))
    elif d.design_note:
        s.blocks.append(Missing(d.design_note))
    return s


#: The diagnosis section's sentence when no effect was excluded.
NOTHING_EXCLUDED = "Excluded effects (`--exclude`): none."


def excluded(d: ReportData) -> Paragraph | None:
    """What the diagnosis was not allowed to name (``--exclude``: the diagnosis' own
    ``excluded``, or what was asked when none was made), or None when nothing was."""
    names = (
        list(diagnosis_json(d.diagnosis).get("excluded") or [])
        if d.diagnosis is not None
        else d.exclude
    )
    if names:
        made = "was" if d.diagnosis is not None else "was to be"
        return Paragraph(
            f"Excluded effects (`--exclude`): {', '.join(sorted(names))} — the diagnosis "
            f"{made} made without them in the library of effects it may name."
        )
    return None


def _verdict(doc: Doc) -> Paragraph:
    """The verdict, with the effect named where the reason does not name it already."""
    v = doc.get("verdict") or {}
    status = v.get("status", "none")
    reason = str(v.get("reason", ""))
    what = ""
    if status == "identified" and v.get("effect"):
        params = f" ({_params(v.get('params'))})" if v.get("params") else ""
        what = (f" {v['effect']}" if str(v["effect"]) not in reason else "") + params
    return Paragraph(f"Verdict — {status}{what}: {reason}".strip())


def _noise_floor(doc: Doc) -> list[Block]:
    """The noise floor, part by part (none without parts)."""
    floor = doc.get("noise_floor") or {}
    parts = floor.get("parts") or {}
    if not parts:
        return []
    cmax = floor.get("correlation_time_max_min")
    return [
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
                *_thermometer_rows(floor.get("thermometers") or {}),
                *[[f"floor of run {r}", fmt(x, 3), "the run's series pooled"]
                  for r, x in (floor.get("per_run_um") or {}).items()],
                ["thermal time constants (min)",
                 ", ".join(f"{k} {fmt(x, 0)}" for k, x in
                           (floor.get("thermal_time_constants_min") or {}).items()),
                 str(floor.get("thermal_time_constants", ""))],
            ],
        )
    ]  # fmt: skip


def _thermometer_rows(th: dict[str, Any]) -> list[list[str]]:
    """The held-out floor as the thermal camera's reading noise and the rest (none without)."""
    if th.get("chips_um") is None:
        return []
    ci = th.get("chips_ci95")
    scatter = ", ".join(f"{r} {fmt(v, 3)} K" for r, v in (th.get("reading_noise_k") or {}).items())
    return [
        ["of the held-out floor: the thermal camera's reading noise through the model",
         fmt(th.get("thermometers_um"), 3), f"each ROI's scatter {scatter}; {th.get('how', '')}"],
        ["of the held-out floor: the chips' and poses' repeatability", fmt(th["chips_um"], 3),
         "the rest in quadrature" + (f"; 95 % interval {fmt(ci[0], 3)}–{fmt(ci[1], 3)}" if ci
                                     else "")],
    ]  # fmt: skip


def _how_far(doc: Doc) -> Table:
    """The nominal model and the chosen effect: noise floor, α, RMS, the gap closed."""
    b = doc.get("baseline") or {}
    hf = doc.get("how_far") or {}
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
    return Table("How far: the nominal model and the chosen effect (µm)", ["", "value", ""], rows)


def _diagnosed_prediction(shrink: pl.DataFrame) -> Table:
    """The held-out runs predicted with α and the identified effect."""
    return Table(
        "The held-out runs predicted with α and the identified effect (`thermrs predict "
        "--diagnosis`): RMS of measured − predicted over every visit, both axes, each "
        "series' mean removed (µm)",
        ["run", "camera", "nominal model", "with the effect", "shrink (%)", "visits"],
        [
            [r["run"], r["camera"], fmt(r["nominal_rms_um"], 3),
             fmt(r["diagnosed_rms_um"], 3), fmt(100 * r["shrink"], 1),
             str(r["n_visits"])]
            for r in shrink.iter_rows(named=True)
        ],
    )  # fmt: skip


def _where(doc: Doc) -> list[Block]:
    """Where the nominal residual lies, largest share first (the first twelve)."""
    loc = sorted(doc.get("location") or [], key=lambda r: -float(r.get("share") or 0))
    if not loc:
        return []
    rows = [
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
    ]
    return [
        Table(
            "Where: the nominal model's residual by run, camera, axis and phase (largest "
            "share first)",
            ["run", "camera", "axis", "phase", "rms (µm)", "share (%)", "visits"],
            rows,
        )
    ]


def _drivers(doc: Doc) -> list[Block]:
    """What the residual follows."""
    drivers = doc.get("drivers") or []
    if not drivers:
        return []
    rows = [
        [
            r["driver"],
            axis_name(r["axis"]) if r.get("axis") else "—",
            fmt(r["corr"], 3),
            f"{float(r['p']):.2g}",
        ]
        for r in drivers
    ]
    return [
        Table(
            "What the residual follows: correlation with temperatures, rates, ambient, time",
            ["driver", "chip axis", "correlation", "p"],
            rows,
        )
    ]


def _whiteness(doc: Doc) -> list[Block]:
    """Whether the nominal residual is white."""
    w = doc.get("whiteness")
    if not w:
        return []
    p = w.get("ljung_box_p")
    if p is None:
        return [
            Paragraph(
                "Whiteness of the nominal residual: not tested (too few held-out visits per "
                "series for a Ljung–Box test)."
            )
        ]
    return [
        Paragraph(
            f"Whiteness of the nominal residual: Ljung–Box p = {float(p):.2g}, "
            f"lag-1 autocorrelation {fmt(w['rho1'], 3)}, {fmt(w['n_eff'], 0)} effective "
            f"samples: {'white (noise)' if w.get('white') else 'structured (not noise)'}."
        )
    ]


def _ranking_row(r: Doc) -> list[str]:
    evidence = r.get("evidence") or {}
    return [
        r["effect"],
        _params(r.get("params")),
        fmt(r.get("train_rms_um"), 3),
        fmt(r.get("holdout_rms_um"), 3),
        fmt(r.get("shrink"), 3),
        fmt(evidence.get("delta_aicc"), 1),
        _yes_no(evidence.get("placebo_beaten")),
        implausible(r["effect"], r.get("params") or {}) or _yes_no(evidence.get("plausible")),
    ]


def _ranking(doc: Doc) -> list[Block]:
    """Every effect of the library, fitted on the training runs, judged on the held-out ones."""
    ranking = doc.get("ranking") or []
    if not ranking:
        return []
    return [
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
            [_ranking_row(r) for r in ranking],
        )
    ]


def _confounded(doc: Doc) -> Block:
    """The confounded pairs and where the runs tell them apart, or that there are none."""
    conf = doc.get("confounded") or []
    if not conf:
        return Paragraph("No two candidate effects were confounded.")
    return Table(
        "Confounded candidates: how alike their signatures are on these runs, and where "
        "the runs tell them apart best",
        ["effects", "similarity (cos)", "on these runs"],
        [[" / ".join(c["effects"]), fmt(c.get("cos"), 3), c.get("separate_by", "")] for c in conf],
    )


def _residual_figure(d: ReportData, colours: Mapping[str, str]) -> Block:
    """The held-out runs' residuals, nominal and with the chosen effect."""
    res = diagnosis_residuals(d.diagnosis)
    if res is None or not res.height:
        return Missing("The diagnosis carries no per-visit residuals: no figure.")
    return Figure(
        "diagnosis",
        "Residuals of the held-out runs: nominal model (faint) and with the chosen "
        "effect (bold), per camera and chip axis.",
        fig_diagnosis(res, colours),
    )


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
