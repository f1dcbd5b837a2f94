"""What extraction skipped and why, per recording."""

from __future__ import annotations

from typing import Any

from thermrs.numbers import (
    fmt,
)
from thermrs.report.blocks import Missing, Paragraph, Section, Table
from thermrs.report.data import (
    ReportData,
)
from thermrs.report.sections.common import join


def section(d: ReportData) -> Section:
    s = Section("extraction", "What extraction skipped and why")
    # Runs cut from one recording share its extraction: shown once.
    groups: dict[object, list[Any]] = {}
    for run in d.runs:
        key = id(run.extract_report) if run.extract_report is not None else run.name
        groups.setdefault(key, []).append(run)
    for runs in groups.values():
        first = runs[0]
        rep = first.extract_report
        if len(runs) > 1:
            title = f"{join([r.name for r in runs])} (cut from {first.recording})"
        else:
            title = f"{first.name} ({first.source})"
        sub = Section(f"extraction-{first.name}", title)
        rows = []
        for r in runs:
            if r.frames_by_status is None:
                continue
            total = sum(r.frames_by_status.values())
            rows += [
                [r.name, k, f"{v:,}", fmt(100 * v / total if total else None, 1)]
                for k, v in r.frames_by_status.items()
            ]
        if rows:
            sub.blocks.append(
                Table("CCD frames by status", ["run", "status", "frames", "share (%)"], rows)
            )
        for r in runs:
            if r.frames_by_status is None:
                sub.blocks.append(
                    Missing(
                        f"{r.name}: no frames table beside the run's tables: frame counts by "
                        "status are not available."
                    )
                )
            if r.joints == 0:
                sub.blocks.append(
                    Missing(
                        f"{r.name}: no joint states, so every spot frame counted as at its "
                        "camera's pose (visits could not be checked against the joints)."
                    )
                )
            elif r.joints is None:
                sub.blocks.append(Missing(f"{r.name}: no joints table beside the run's tables."))
        known = [r for r in runs if r.joints]
        if known:
            sub.blocks.append(
                Paragraph(
                    "Joint states read: " + ", ".join(f"{r.name} {r.joints:,}" for r in known) + "."
                )
            )
        if rep is None:
            sub.blocks.append(
                Missing(
                    "Given as extracted tables: the extraction's report (skipped messages and "
                    "why, losses) is not stored beside them. Give the recording to see it."
                )
            )
        else:
            msg = ", ".join(f"{k}: {v:,}" for k, v in sorted(rep.messages.items()))
            sub.blocks.append(
                Paragraph(
                    f"Read {rep.file_bytes / 1e6:,.1f} MB in {rep.chunks:,} chunks"
                    f"{' using the summary' if rep.used_summary else ' without a summary'}; "
                    f"messages per topic: {msg or 'none'}; other topics: {rep.other_messages:,}."
                )
            )
            if rep.skipped:
                sub.blocks.append(
                    Table(
                        "Skipped messages",
                        ["topic: reason (first seen)", "count"],
                        [
                            [rep.skipped_examples.get(k, k), f"{v:,}"]
                            for k, v in rep.skipped.items()
                        ],
                    )
                )
            else:
                sub.blocks.append(Paragraph("No message was skipped."))
            for loss in rep.losses:
                sub.blocks.append(Missing(f"Data loss: {loss.get('detail', loss)}"))
            if rep.recovered_messages:
                sub.blocks.append(
                    Paragraph(
                        f"{rep.recovered_messages:,} complete messages recovered from a cut chunk."
                    )
                )
        s.subsections.append(sub)
    return s
