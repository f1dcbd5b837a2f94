"""Prediction against measurement: the held-out runs predicted from their own temperatures."""

from __future__ import annotations

from collections.abc import Mapping

from thermrs.numbers import fmt_alpha
from thermrs.report.blocks import Figure, Missing, Paragraph, Section
from thermrs.report.data import ReportData
from thermrs.report.figures import fig_prediction
from thermrs.report.sections.common import join

__all__ = ["section"]


def section(d: ReportData, colours: Mapping[str, str]) -> Section:
    """The prediction section: the held-out runs predicted with the fitted α."""
    s = Section("prediction", "Prediction against measurement")
    if d.series is None or d.fit is None:
        s.blocks.append(Missing(d.fit_note or "Nothing was predicted."))
        return s
    a = d.fit["alpha_per_k"]["value"]
    if d.prediction_in_sample:
        s.blocks.append(
            Missing(
                f"One run only: nothing was held out, so the prediction below is of "
                f"{join(d.train)} itself with the α fitted on it (an in-sample check, not a "
                "prediction). Give more runs to predict runs kept out of the fit."
            )
        )
    else:
        s.blocks.append(
            Paragraph(
                f"Every visit of the held-out run{'s' if len(d.holdout) > 1 else ''} "
                f"{join(d.holdout)} predicted from its own temperatures with the forward "
                f"model and α = {fmt_alpha(a)} ×10⁻⁶/K fitted on {join(d.train)}; below, "
                "measured − predicted."
            )
        )
    for run in d.holdout or d.train:
        s.blocks.append(
            Figure(
                f"prediction-{run}",
                f"{run}: predicted (dashed) against measured (thin line) drift along chip x (u) "
                "and y (v), and the residual (measured − predicted).",
                fig_prediction(d.series, colours, run),
            )
        )
    return s
