"""Defaults shared by the library, the CLI and the report, written once. Plain numbers, no
import: the CLI reads them at start-up (``thermrs --help`` stays fast); a test checks that the
library's own constants agree."""

from __future__ import annotations

__all__ = ["DESIGN_BUDGET_H", "ISO_TOLERANCE_UM", "ISO_WINDOW", "VISIT_TOLERANCE_DEG"]

#: The joint tolerance of a visit (°): a CCD frame counts as at its camera's pose when every
#: joint is within this of the taught angle (:data:`thermrs.visits.DEFAULT_TOLERANCE_DEG`).
VISIT_TOLERANCE_DEG = 0.05
#: Visits per ISO 9283-style window (``thermrs drift --window``, the report).
ISO_WINDOW = 10
#: Settling tolerance of the barycentre, µm (``thermrs drift --tolerance-um``, the report).
ISO_TOLERANCE_UM = 1.0
#: The most recording hours a designed experiment asks for (``thermrs design --budget-h``, the
#: report's design).
DESIGN_BUDGET_H = 24.0
