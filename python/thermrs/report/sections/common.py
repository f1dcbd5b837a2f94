"""Prose helpers the report's sections share."""

from __future__ import annotations

from collections.abc import Sequence

from thermrs.report.data import ReportData
from thermrs.report.figures import temperature_colours

__all__ = ["axis_name", "join", "series_colours"]


def axis_name(axis: str) -> str:
    """A chip axis in words: ``"x (u)"`` or ``"y (v)"``."""
    return f"{'x' if axis == 'u' else 'y'} ({axis})"


def join(items: Sequence[str]) -> str:
    """``a``, ``a and b``, ``a, b and c``."""
    items = list(items)
    if len(items) <= 1:
        return "".join(items)
    return ", ".join(items[:-1]) + " and " + items[-1]


def series_colours(d: ReportData) -> dict[str, str]:
    """One colour per temperature series throughout the report."""
    return temperature_colours(sorted({n for r in d.runs for n in r.roi_names}))
