"""The report as a document: its sections in order, composed from
:class:`thermrs.report.data.ReportData`. The blocks are in :mod:`thermrs.report.blocks`, one
module per section in :mod:`thermrs.report.sections`; rendering (HTML, Markdown) is in
:mod:`thermrs.report.render`.

Numbers are printed with fixed precision, the same everywhere: α in 10⁻⁶/K with three
decimals, drift and RP in µm with two (residual RMS and noise with three), temperatures in °C
with two, τ in minutes with one, shares in per cent with one.
"""

from __future__ import annotations

from thermrs.numbers import fmt
from thermrs.report.blocks import SECTION_IDS, Figure, Missing, Paragraph, Section, Table
from thermrs.report.data import ReportData
from thermrs.report.figures import camera_colours
from thermrs.report.sections import (
    diagnosis,
    extraction,
    heating,
    iso,
    prediction,
    rig,
    runs,
    summary,
    tables,
)

__all__ = [
    "SECTION_IDS",
    "Figure",
    "Missing",
    "Paragraph",
    "Section",
    "Table",
    "compose",
    "fmt",
]


def compose(d: ReportData) -> list[Section]:
    """Every section of the report, in order (:data:`SECTION_IDS`)."""
    colours = camera_colours([c.name for c in d.rig.cameras])
    sections = [
        summary.section(d, colours),
        rig.section(d, colours),
        runs.section(d, colours),
        heating.section(d),
        tables.section(d),
        prediction.section(d, colours),
        iso.section(d, colours),
        diagnosis.section(d, colours),
        extraction.section(d),
    ]
    assert tuple(x.id for x in sections) == SECTION_IDS
    return sections
