"""Rendering a composed report (:mod:`thermrs.report.document`) as one self-contained HTML
file and as Markdown with its figures as SVG files beside it.

The HTML has no script and loads nothing: styles are inline, figures are inline SVG, and a
Content-Security-Policy forbids every request, so it opens offline and mails as one file.
"""

from __future__ import annotations

import html
import re
from collections.abc import Sequence
from pathlib import Path
from urllib.parse import quote

from thermrs.report.blocks import Figure, Missing, Paragraph, Section, Table

__all__ = ["to_html", "to_markdown"]

CSS = """
:root { color-scheme: light; }
body { font: 15px/1.45 system-ui, -apple-system, "Segoe UI", Roboto, sans-serif; color: #1b1f24;
  max-width: 1040px; margin: 2rem auto; padding: 0 1.25rem; }
h1 { font-size: 1.7rem; margin-bottom: .2rem; }
h2 { font-size: 1.3rem; border-bottom: 1px solid #d0d7de; padding-bottom: .2rem;
  margin-top: 2.2rem; }
h3 { font-size: 1.05rem; margin-top: 1.4rem; }
.meta { color: #57606a; font-size: .9rem; }
nav ol { columns: 2; font-size: .92rem; }
table { border-collapse: collapse; font-size: .82rem; margin: .6rem 0 1rem; display: block;
  overflow-x: auto; }
caption { caption-side: top; text-align: left; font-weight: 600; padding: .3rem 0; }
th, td { border: 1px solid #d0d7de; padding: .2rem .45rem; text-align: left; }
th { background: #f6f8fa; white-space: nowrap; }
td { min-width: 2.5em; max-width: 30em; }
td.n { text-align: right; white-space: nowrap; font-variant-numeric: tabular-nums; }
figure { margin: 1rem 0 1.4rem; break-inside: avoid; }
figure svg { max-width: 100%; height: auto; }
figcaption { color: #57606a; font-size: .85rem; }
code { font-size: .92em; background: #f6f8fa; padding: 0 .2em; border-radius: 3px; }
.missing { border-left: 4px solid #d4a72c; background: #fff8c5; padding: .4rem .7rem; }
section#summary p { font-size: 1.02rem; }
@media print { body { max-width: none; margin: 0; } h2 { break-before: auto; }
  table { display: table; } }
"""

CSP = "default-src 'none'; style-src 'unsafe-inline'; img-src data:"


def _e(text: str) -> str:
    """Escaped text; `code` spans become <code>."""
    return re.sub(r"`([^`]+)`", r"<code>\1</code>", html.escape(text, quote=True))


#: A cell that is a number (or numbers, a range, "—"): right-aligned, never wrapped.
NUMERIC = re.compile(r"^[−+\-–→0-9.,%\s—]*[0-9—][−+\-–→0-9.,%\s—]*$")


def _td(cell: str) -> str:
    cls = ' class="n"' if NUMERIC.match(cell) else ""
    return f"<td{cls}>{_e(cell)}</td>"


def _html_block(b: object) -> str:
    if isinstance(b, Paragraph):
        return f"<p>{_e(b.text)}</p>"
    if isinstance(b, Missing):
        return f'<p class="missing"><strong>Not shown:</strong> {_e(b.text)}</p>'
    if isinstance(b, Table):
        head = "".join(f"<th>{_e(c)}</th>" for c in b.columns)
        body = "".join("<tr>" + "".join(_td(c) for c in row) + "</tr>" for row in b.rows)
        return (
            f"<table><caption>{_e(b.caption)}</caption><thead><tr>{head}</tr></thead>"
            f"<tbody>{body}</tbody></table>"
        )
    if isinstance(b, Figure):
        return (
            f'<figure id="fig-{_e(b.name)}" data-figure="{_e(b.name)}">{b.svg}'
            f"<figcaption>{_e(b.caption)}</figcaption></figure>"
        )
    raise TypeError(f"unknown block {type(b).__name__}")


def _html_section(s: Section, level: int) -> str:
    parts = [f'<section id="{_e(s.id)}"><h{level}>{_e(s.title)}</h{level}>']
    parts += [_html_block(b) for b in s.blocks]
    parts += [_html_section(x, level + 1) for x in s.subsections]
    parts.append("</section>")
    return "\n".join(parts)


def to_html(sections: Sequence[Section], *, title: str, meta: str) -> str:
    """The report as one self-contained HTML document."""
    toc = "".join(f'<li><a href="#{_e(s.id)}">{_e(s.title)}</a></li>' for s in sections)
    body = "\n".join(_html_section(s, 2) for s in sections)
    return (
        "<!DOCTYPE html>\n"
        '<html lang="en"><head><meta charset="utf-8">'
        f'<meta http-equiv="Content-Security-Policy" content="{CSP}">'
        '<meta name="viewport" content="width=device-width, initial-scale=1">'
        f"<title>{_e(title)}</title><style>{CSS}</style></head>\n<body>"
        f'<header><h1>{_e(title)}</h1><p class="meta">{_e(meta)}</p></header>'
        f"<nav><ol>{toc}</ol></nav>\n<main>{body}</main></body></html>\n"
    )


def _md_cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def _md_block(b: object, fig_dir: Path, rel: str, written: dict[str, Path]) -> str:
    if isinstance(b, Paragraph):
        return b.text
    if isinstance(b, Missing):
        return f"> **Not shown:** {b.text}"
    if isinstance(b, Table):
        lines = [f"*{b.caption}*", ""]
        lines.append("| " + " | ".join(_md_cell(c) for c in b.columns) + " |")
        lines.append(
            "|" + "|".join(":--" if i == 0 else "--:" for i in range(len(b.columns))) + "|"
        )
        lines += ["| " + " | ".join(_md_cell(c) for c in row) + " |" for row in b.rows]
        return "\n".join(lines)
    if isinstance(b, Figure):
        # A file name any Markdown viewer links to: a run's "#" or a space would cut the link.
        stem = re.sub(r"[^A-Za-z0-9._-]+", "-", b.name)
        path = fig_dir / f"{stem}.svg"
        written[b.name] = path
        svg = b.svg
        if "xmlns=" not in svg[:300]:
            svg = svg.replace("<svg", '<svg xmlns="http://www.w3.org/2000/svg"', 1)
        path.write_text(svg, encoding="utf-8")
        link = quote(f"{rel}/{stem}.svg")
        return f"![{b.caption}]({link})\n\n*{b.caption}*"
    raise TypeError(f"unknown block {type(b).__name__}")


def _md_section(s: Section, level: int, fig_dir: Path, rel: str, w: dict[str, Path]) -> str:
    parts = [f"{'#' * level} {s.title}"]
    parts += [_md_block(b, fig_dir, rel, w) for b in s.blocks]
    parts += [_md_section(x, level + 1, fig_dir, rel, w) for x in s.subsections]
    return "\n\n".join(parts)


def to_markdown(
    sections: Sequence[Section], *, title: str, meta: str, fig_dir: Path, rel: str
) -> tuple[str, dict[str, Path]]:
    """The report as Markdown; figures are written as SVG files into ``fig_dir`` (linked as
    ``rel/NAME.svg``). Returns the text and the figure files written."""
    fig_dir.mkdir(parents=True, exist_ok=True)
    written: dict[str, Path] = {}
    body = "\n\n".join(_md_section(s, 2, fig_dir, rel, written) for s in sections)
    return f"# {title}\n\n*{meta}*\n\n{body}\n", written
