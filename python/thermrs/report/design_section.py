"""The report's "experiment that settles it", kept importable here: it moved to
:mod:`thermrs.report.sections.design`."""

from thermrs.report.sections.design import design_section, fig_rival_drift, section_for

__all__ = ["design_section", "fig_rival_drift", "section_for"]
