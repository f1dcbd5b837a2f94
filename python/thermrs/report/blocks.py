"""The report's building blocks: sections of paragraphs, tables, figures and notes of what is
missing. Sections build them (:mod:`thermrs.report.sections`); renderers read them
(:mod:`thermrs.report.render`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

__all__ = ["SECTION_IDS", "Block", "Figure", "Missing", "Paragraph", "Section", "Table"]


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
