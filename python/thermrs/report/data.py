"""What a report shows, as data: its runs (:class:`RunInput`) and every number on the page
(:class:`ReportData`). Nothing here computes: :func:`thermrs.analyses.report_data.report_data`
builds a :class:`ReportData` from the results the commands render (``thermrs fit``,
``predict``, ``drift``, ``diagnose``, ``design``, ``predict --diagnosis``), and
:mod:`thermrs.report.document` renders it.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import polars as pl

from thermrs.defaults import ISO_TOLERANCE_UM, ISO_WINDOW
from thermrs.rig import Rig

if TYPE_CHECKING:  # pragma: no cover - the results' types, for type checkers only
    from thermrs.design import DesignResult
    from thermrs.diagnose.baselines import BaselineComparison
    from thermrs.diagnose.result import Diagnosis
    from thermrs.ingest import ExtractReport

__all__ = [
    "ISO_TOLERANCE_UM",
    "ISO_WINDOW",
    "ReportData",
    "RunInput",
    "Step",
    "diagnosis_json",
    "diagnosis_residuals",
]

Step = Callable[[str], None]


@dataclass(frozen=True)
class RunInput:
    """One run as the report sees it.

    Attributes
    ----------
    name
        The run's name (the run table's ``run`` column).
    table
        Its run table (:func:`thermrs.fit.run_table`).
    source
        Where it came from (a path, or a description).
    temperatures
        The thermal and ambient readings (long table of :attr:`thermrs.Extraction.temperatures`),
        or None where not available.
    joints
        Joint states read, or None where not known.
    frames_by_status
        CCD frames by status, or None where the frames table is not available.
    extract_report
        The extraction's report (skipped messages, losses), or None for extracted tables (the
        report is not stored beside them).
    data_loss
        Whether part of the recording was lost.
    recording
        The recording it was extracted from (several runs may share one), or None.
    """

    name: str
    table: pl.DataFrame
    source: str
    temperatures: pl.DataFrame | None = None
    joints: int | None = None
    frames_by_status: dict[str, int] | None = None
    extract_report: ExtractReport | None = None
    data_loss: bool = False
    recording: str | None = None

    @property
    def roi_names(self) -> list[str]:
        """Temperature series of the run table (ROIs and ``ambient``)."""
        return sorted(c[: -len("_c")] for c in self.table.columns if c.endswith("_c"))


@dataclass
class ReportData:
    """Everything a report shows, computed once by
    :func:`thermrs.analyses.report_data.report_data` (see the module docstring)."""

    rig: Rig
    rig_view: dict[str, Any]
    runs: list[RunInput]
    train: list[str]
    holdout: list[str]
    fit: dict[str, Any] | None
    fit_note: str | None
    alphas: dict[str, float]
    prediction: pl.DataFrame | None
    prediction_in_sample: bool
    series: pl.DataFrame | None
    curves: pl.DataFrame
    iso: dict[str, Any]
    iso_windows: pl.DataFrame
    table4: pl.DataFrame
    diagnosis: Diagnosis | None
    diagnosis_note: str | None
    title: str
    paper_reference: bool = False
    #: With an identified effect: the held-out runs predicted by the nominal model and by the
    #: diagnosed one (:func:`thermrs.compensate.shrink_table`), else None.
    diagnosed_prediction: pl.DataFrame | None = None
    #: With an ambiguous diagnosis: the experiment that settles it
    #: (:class:`thermrs.design.DesignResult`) and its rivals' forecast drift on it
    #: (:func:`thermrs.design.rival_drift`), or why there is none.
    design: DesignResult | None = None
    design_drift: pl.DataFrame | None = None
    design_note: str | None = None
    notes: list[str] = field(default_factory=list)
    #: The effects the diagnosis made here was asked not to name (``--exclude``); a diagnosis
    #: given or made says its own (its ``excluded``).
    exclude: list[str] = field(default_factory=list)
    #: With ``report_data(baselines=True)`` and a diagnosis: the regressions beside the physical
    #: models (:class:`thermrs.diagnose.baselines.BaselineComparison`), else None.
    baselines: BaselineComparison | None = None

    def run(self, name: str) -> RunInput:
        """The run called ``name``."""
        for r in self.runs:
            if r.name == name:
                return r
        raise KeyError(name)


def diagnosis_json(diag: Any) -> dict[str, Any]:
    """The diagnosis as its JSON document (an object with ``to_json()``, or a mapping)."""
    if isinstance(diag, Mapping):
        return dict(diag)
    doc = diag.to_json()
    if not isinstance(doc, dict):
        raise TypeError("Diagnosis.to_json() must return a dict")
    return doc


def diagnosis_residuals(diag: Any) -> pl.DataFrame | None:
    """The diagnosis' per-visit residuals, or None."""
    res = getattr(diag, "residuals", None)
    return res if isinstance(res, pl.DataFrame) and res.height else None
