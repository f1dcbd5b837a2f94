"""``thermrs report``: the report a person reads (issue #11).

One self-contained HTML file (inline SVG figures, no script, no request leaves it) and a
Markdown twin with its figures as SVG files beside it, for one run or a campaign:

- summary in sentences; the rig (poses, where the laser meets each chip, incidence);
- per run the spot drift along both chip axes per camera with the ROI temperatures on the same
  time axis (the paper's Figure 5), and the fitted heating curves with τ and standard errors;
- Table 4/6/7-style tables; prediction against measurement with the residual;
- ISO 9283-style repeatability cold against warm; the diagnosis (with held-out runs);
- what extraction skipped and why.

A section whose input is missing (no thermal readings, one run only, no joint states, no
diagnoser) says so where it would be. This package renders and computes nothing: every number
is in a :class:`~thermrs.report.data.ReportData` that
:func:`thermrs.analyses.report_data.report_data` builds from the results the commands render
(``thermrs predict``, ``drift``, ``diagnose``, ``design``); the document
:mod:`thermrs.report.document`, figures :mod:`thermrs.report.figures`, rendering
:mod:`thermrs.report.render`. Reading runs and writing a report:
:mod:`thermrs.analyses.report_runs`, :func:`thermrs.analyses.report.write_report`; the demo
:mod:`thermrs.analyses.demo`.

Example
-------
>>> from thermrs.analyses.report import write_report  # doctest: +SKIP
>>> from thermrs.analyses.report_runs import load_runs  # doctest: +SKIP
>>> rig = thermrs.load_rig()  # doctest: +SKIP
>>> runs = load_runs("campaign.mcap", rig)  # each run of the file  # doctest: +SKIP
>>> write_report("report.html", runs=runs, rig=rig)  # doctest: +SKIP
"""

from __future__ import annotations

import os
import shutil
import subprocess
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from thermrs.atomic import write_atomic, write_dir, write_text
from thermrs.errors import InputError
from thermrs.moved import handed_on
from thermrs.report.blocks import Paragraph, Section
from thermrs.report.data import ReportData, RunInput, Step
from thermrs.report.document import compose
from thermrs.report.render import to_html, to_markdown

__all__ = [
    "ReportData",
    "RunInput",
    "Written",
    "find_chromium",
    "print_pdf",
    "write_document",
]


#: Names that moved to :mod:`thermrs.analyses` (they read runs or compute), each with its new
#: module. Handed on when first asked, with a warning: this package renders, sits below
#: :mod:`thermrs.analyses` and imports nothing of it.
MOVED_TO_ANALYSES = {
    "write_report": "thermrs.analyses.report",
    "load_runs": "thermrs.analyses.report_runs",
    "load_run": "thermrs.analyses.report_runs",
    "run_from_extraction": "thermrs.analyses.report_runs",
}


__getattr__ = handed_on("thermrs.report", MOVED_TO_ANALYSES)


@dataclass(frozen=True)
class Written:
    """What :func:`write_report` (or :func:`write_document`) wrote."""

    html: Path
    markdown: Path | None
    figures: dict[str, Path]
    pdf: Path | None
    html_bytes: int


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("thermrs")
    except PackageNotFoundError:  # pragma: no cover - running from a source tree
        return "unknown"


def write_document(
    data: ReportData,
    out: str | Path,
    *,
    intro: str | None = None,
    markdown: bool = True,
    pdf: bool = False,
    step: Step | None = None,
) -> Written:
    """Render a report whose numbers are computed
    (:func:`thermrs.analyses.report_data.report_data`) and write it: the HTML file, its
    Markdown twin (``OUT.md``, figures in ``OUT_files/``), with ``pdf`` the PDF
    (``OUT.pdf``), each atomically.

    Parameters
    ----------
    data
        Everything the report shows.
    out
        The HTML file.
    intro
        A paragraph placed first in the summary.
    markdown, pdf
        Also write the Markdown twin; also print to PDF with headless Chromium.
    step
        Called with a short description before each stage.

    Returns
    -------
    Written
        The files written.

    Raises
    ------
    InputError
        ``pdf`` without Chromium to print with.

    Examples
    --------
    >>> from thermrs.analyses.report_data import report_data
    >>> write_document(report_data(runs, rig), "report.html")  # doctest: +SKIP
    """
    out = Path(out)
    _say(step, "drawing figures")
    sections = compose(data)
    if intro:
        sections[0].blocks.insert(0, Paragraph(intro))
    meta = _meta(data)
    _say(step, "writing the report")
    text = to_html(sections, title=data.title, meta=meta)
    write_text(out, text)
    md_path, figures = _write_markdown(out, sections, data, meta) if markdown else (None, {})
    pdf_path = None
    if pdf:
        _say(step, "printing to PDF")
        pdf_path = print_pdf(out, out.with_suffix(".pdf"))
    return Written(
        html=out, markdown=md_path, figures=figures, pdf=pdf_path, html_bytes=len(text.encode())
    )


def _say(step: Step | None, what: str) -> None:
    if step is not None:
        step(what)


def _meta(data: ReportData) -> str:
    """The line under the title: version, rig, runs, which were fitted and held out."""
    return (
        f"thermrs {_version()} · rig {Path(data.rig.source).name} · "
        f"runs {', '.join(r.name for r in data.runs)} · "
        f"α fitted on {', '.join(data.train)}"
        + (f", held out {', '.join(data.holdout)}" if data.holdout else "")
    )


def _write_markdown(
    out: Path, sections: list[Section], data: ReportData, meta: str
) -> tuple[Path, dict[str, Path]]:
    """The Markdown twin ``OUT.md`` with its figures in ``OUT_files/`` (written whole)."""
    stem = out.name[: -len(".html")] if out.name.endswith(".html") else out.name
    md_path = out.with_name(f"{stem}.md")
    fig_dir = out.with_name(f"{stem}_files")
    rendered: list[tuple[str, dict[str, Path]]] = []

    def draw(staging: Path) -> None:
        rendered.append(
            to_markdown(sections, title=data.title, meta=meta, fig_dir=staging, rel=fig_dir.name)
        )

    write_dir(fig_dir, draw)
    md, written = rendered[0]
    write_text(md_path, md)
    return md_path, {k: fig_dir / v.name for k, v in written.items()}


def _run(argv: list[str], **kw: Any) -> subprocess.CompletedProcess[str]:
    """Run Chromium; one that cannot be started is bad input (``THERMRS_CHROMIUM``), not a
    failed write."""
    try:
        return subprocess.run(argv, **kw)
    except OSError as e:
        raise InputError(f"cannot run Chromium {argv[0]}: {e.strerror or e}") from None


def find_chromium() -> str | None:
    """The Chromium to print and test with: ``THERMRS_CHROMIUM``, else ``chromium``,
    ``chromium-browser`` or ``google-chrome`` on PATH."""
    env = os.environ.get("THERMRS_CHROMIUM")
    if env:
        return env if Path(env).exists() else shutil.which(env)
    for name in ("chromium", "chromium-browser", "google-chrome"):
        path = shutil.which(name)
        if path:
            return path
    return None


def print_pdf(html_path: str | Path, pdf_path: str | Path, *, timeout_s: float = 120.0) -> Path:
    """Print an HTML file to PDF with headless Chromium (A4, backgrounds, no header/footer),
    written atomically."""
    exe = find_chromium()
    if exe is None:
        raise InputError("printing to PDF needs Chromium (`chromium` on PATH, or THERMRS_CHROMIUM)")
    html_path, pdf_path = Path(html_path).resolve(), Path(pdf_path)

    def chromium_print(tmp: Path) -> None:
        with tempfile.TemporaryDirectory(prefix="thermrs-chromium-") as profile:
            p = _run(
                [
                    exe,
                    "--headless",
                    "--disable-gpu",
                    "--no-sandbox",
                    "--no-first-run",
                    f"--user-data-dir={profile}",
                    "--no-pdf-header-footer",
                    f"--print-to-pdf={tmp}",
                    html_path.as_uri(),
                ],
                capture_output=True,
                text=True,
                timeout=timeout_s,
                check=False,
            )
        if p.returncode != 0 or tmp.stat().st_size == 0:
            last = (p.stderr.strip().splitlines() or ["no output"])[-1]
            raise InputError(f"Chromium could not print {html_path} to PDF: {last}")

    write_atomic(pdf_path, chromium_print)
    return pdf_path
