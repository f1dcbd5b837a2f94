"""What extraction skipped and why, per recording."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from thermrs.numbers import fmt
from thermrs.report.blocks import Block, Missing, Paragraph, Section, Table
from thermrs.report.data import ReportData, RunInput
from thermrs.report.sections.common import join

if TYPE_CHECKING:  # pragma: no cover
    from thermrs.ingest import ExtractReport

__all__ = ["section"]


def section(d: ReportData) -> Section:
    """One subsection per recording: frames by status, joint states, the extraction's report."""
    s = Section("extraction", "What extraction skipped and why")
    # Runs cut from one recording share its extraction: shown once.
    groups: dict[object, list[Any]] = {}
    for run in d.runs:
        key = id(run.extract_report) if run.extract_report is not None else run.name
        groups.setdefault(key, []).append(run)
    for runs in groups.values():
        first = runs[0]
        if len(runs) > 1:
            title = f"{join([r.name for r in runs])} (cut from {first.recording})"
        else:
            title = f"{first.name} ({first.source})"
        sub = Section(f"extraction-{first.name}", title)
        sub.blocks += _frames(runs)
        sub.blocks += _joints(runs)
        sub.blocks += _report(first.extract_report)
        s.subsections.append(sub)
    return s


def _frames(runs: list[RunInput]) -> list[Block]:
    """CCD frames by status, per run."""
    rows = []
    for r in runs:
        if r.frames_by_status is None:
            continue
        total = sum(r.frames_by_status.values())
        rows += [
            [r.name, k, f"{v:,}", fmt(100 * v / total if total else None, 1)]
            for k, v in r.frames_by_status.items()
        ]
    if not rows:
        return []
    return [Table("CCD frames by status", ["run", "status", "frames", "share (%)"], rows)]


def _joints(runs: list[RunInput]) -> list[Block]:
    """What is missing of frames and joint states, and the joint states read."""
    out: list[Block] = []
    for r in runs:
        if r.frames_by_status is None:
            out.append(
                Missing(
                    f"{r.name}: no frames table beside the run's tables: frame counts by "
                    "status are not available."
                )
            )
        if r.joints == 0:
            out.append(
                Missing(
                    f"{r.name}: no joint states, so every spot frame counted as at its "
                    "camera's pose (visits could not be checked against the joints)."
                )
            )
        elif r.joints is None:
            out.append(Missing(f"{r.name}: no joints table beside the run's tables."))
    known = [r for r in runs if r.joints]
    if known:
        out.append(
            Paragraph(
                "Joint states read: " + ", ".join(f"{r.name} {r.joints:,}" for r in known) + "."
            )
        )
    return out


def _report(rep: ExtractReport | None) -> list[Block]:
    """The extraction's report: what was read, skipped, lost and recovered."""
    if rep is None:
        return [
            Missing(
                "Given as extracted tables: the extraction's report (skipped messages and "
                "why, losses) is not stored beside them. Give the recording to see it."
            )
        ]
    msg = ", ".join(f"{k}: {v:,}" for k, v in sorted(rep.messages.items()))
    out: list[Block] = [
        Paragraph(
            f"Read {rep.file_bytes / 1e6:,.1f} MB in {rep.chunks:,} chunks"
            f"{' using the summary' if rep.used_summary else ' without a summary'}; "
            f"messages per topic: {msg or 'none'}; other topics: {rep.other_messages:,}."
        )
    ]
    if rep.skipped:
        out.append(
            Table(
                "Skipped messages",
                ["topic: reason (first seen)", "count"],
                [[rep.skipped_examples.get(k, k), f"{v:,}"] for k, v in rep.skipped.items()],
            )
        )
    else:
        out.append(Paragraph("No message was skipped."))
    out += [Missing(f"Data loss: {loss.get('detail', loss)}") for loss in rep.losses]
    if rep.recovered_messages:
        out.append(
            Paragraph(f"{rep.recovered_messages:,} complete messages recovered from a cut chunk.")
        )
    return out
