"""The campaign page: α and drift per run across the campaign on one page (does the robot
change over weeks?), with the held-out check of a rule. Markdown (``.md``) or a self-contained
HTML file (``.html``, the figure inline as SVG, no network)."""

from __future__ import annotations

import html
import io
from pathlib import Path

import polars as pl

from thermrs.ingest import atomic_tmp, publish

__all__ = ["write_page"]


def _markdown(per_run: pl.DataFrame, folds: pl.DataFrame | None, title: str) -> str:
    lines = [
        f"# {title}",
        "",
        "| recording | run | date | speed (°/s) | α (10⁻⁶/K) | "
        "95 % interval | RMS (µm) | largest drift (µm) |",
        "| --- | --- | --- | ---: | ---: | --- | ---: | ---: |",
    ]
    for r in per_run.iter_rows(named=True):
        speed = "" if r["speed_deg_s"] is None else f"{r['speed_deg_s']:.0f}"
        lines.append(
            f"| {r['recording']} | {r['run']} | {r['date']} | {speed} | "
            f"{r['alpha_per_k'] * 1e6:.2f} | {r['ci95_low'] * 1e6:.2f} … "
            f"{r['ci95_high'] * 1e6:.2f} | {r['rms_um']:.2f} | {r['drift_um']:.2f} |"
        )
    if folds is not None:
        lines += [
            "",
            "## Held out",
            "",
            "| fold | training runs | held-out runs | α (10⁻⁶/K) | held-out RMS (µm) |",
            "| --- | ---: | ---: | ---: | ---: |",
        ]
        for f in folds.iter_rows(named=True):
            lines.append(
                f"| {f['fold']} | {f['train_runs']} | {f['holdout_runs']} | "
                f"{f['alpha_per_k'] * 1e6:.2f} | {f['holdout_rms_um']:.2f} |"
            )
    return "\n".join(lines) + "\n"


def _figure(per_run: pl.DataFrame) -> str:
    """α with its interval and the largest drift, per run in time order, as SVG."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    x = list(range(per_run.height))
    labels = [f"{a}#{b}" for a, b in zip(per_run["recording"], per_run["run"], strict=True)]
    a = per_run["alpha_per_k"].to_numpy() * 1e6
    lo = a - per_run["ci95_low"].to_numpy() * 1e6
    hi = per_run["ci95_high"].to_numpy() * 1e6 - a
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(9, 5.5), sharex=True)
    ax1.errorbar(x, a, yerr=[lo, hi], fmt="o", capsize=3)
    ax1.set_ylabel("α (10⁻⁶/K), 95 %")
    ax2.bar(x, per_run["drift_um"].to_numpy())
    ax2.set_ylabel("largest drift (µm)")
    ax2.set_xticks(x, labels, rotation=60, ha="right", fontsize=7)
    fig.tight_layout()
    buf = io.StringIO()
    fig.savefig(buf, format="svg")
    plt.close(fig)
    svg = buf.getvalue()
    return svg[svg.index("<svg") :]


def write_page(
    per_run: pl.DataFrame,
    out: str | Path,
    *,
    folds: pl.DataFrame | None = None,
    title: str = "Campaign: α and drift per run",
) -> Path:
    """Write the campaign page atomically.

    Parameters
    ----------
    per_run
        :func:`thermrs.campaigns.summary.alpha_by_run`.
    out
        ``.md`` (Markdown) or ``.html`` (self-contained, with the figure).
    folds
        :func:`thermrs.campaigns.summary.holdout_by_rule`, if a rule was asked for.
    title
        The page's title.
    """
    out = Path(out)
    md = _markdown(per_run, folds, title)
    if out.suffix == ".html":
        rows = md.splitlines()
        body = "\n".join(html.escape(r) for r in rows)
        text = (
            f"<!doctype html><html><head><meta charset='utf-8'><title>{html.escape(title)}"
            f"</title></head><body><h1>{html.escape(title)}</h1>{_figure(per_run)}"
            f"<pre>{body}</pre></body></html>\n"
        )
    else:
        text = md
    tmp = atomic_tmp(out)
    try:
        tmp.write_text(text, encoding="utf-8")
        publish(tmp, out)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return out
