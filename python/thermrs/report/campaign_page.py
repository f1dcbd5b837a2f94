"""The campaign page: does the robot change over weeks, which speeds drift most, which runs
stand out — α and the largest drift per run against date and against speed, with intervals, a
trend test over time, per-day and per-speed summaries and the held-out check of a rule; one
self-contained HTML file or Markdown with its figures beside it, the same content, tables as
tables (:mod:`thermrs.report.render`)."""

from __future__ import annotations

import datetime
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import polars as pl

from thermrs.atomic import write_dir, write_text
from thermrs.report.blocks import Figure, Paragraph, Section, Table
from thermrs.report.figures import figure, svg
from thermrs.report.render import to_html, to_markdown

if TYPE_CHECKING:  # pragma: no cover
    from thermrs.campaigns.summary import CampaignSummary

__all__ = ["campaign_sections", "write_campaign_page"]


def _f(x: float | None, scale: float = 1.0, fmt: str = ".2f") -> str:
    return "—" if x is None or not np.isfinite(x) else format(x * scale, fmt)


def _days(per_run: pl.DataFrame) -> np.ndarray:
    """Each run's start in days since the campaign's first."""
    t = per_run["start_ns"].to_numpy().astype(np.float64) / 86_400e9
    return t - np.nanmin(t) if len(t) else t


def _fig_time(per_run: pl.DataFrame, trend: dict[str, Any]) -> str:
    """α with its 95 % interval against the day, the fitted trend over it; the largest drift."""
    fig = figure(5.0)
    ax1, ax2 = fig.subplots(2, 1, sharex=True)
    d = _days(per_run)
    a = per_run["alpha_per_k"].to_numpy() * 1e6
    lo = a - per_run["ci95_low"].to_numpy() * 1e6
    hi = per_run["ci95_high"].to_numpy() * 1e6 - a
    ax1.errorbar(d, a, yerr=[lo, hi], fmt="o", capsize=3, label="α per run, 95 %")
    if trend.get("slope_per_k_per_week") is not None and len(d) > 1:
        w = 1.0 / np.maximum(lo + hi, 1e-12) ** 2
        centre = float(np.sum(w * a) / np.sum(w))
        mid = float(np.average(d, weights=w))
        xs = np.array([d.min(), d.max()])
        ax1.plot(
            xs, centre + trend["slope_per_k_per_week"] * 1e6 * (xs - mid) / 7.0, "--", label="trend"
        )
    ax1.set_ylabel("α (10⁻⁶/K)")
    ax1.legend(loc="best")
    ax2.plot(d, per_run["drift_um"].to_numpy(), "s")
    ax2.set_ylabel("largest drift (µm)")
    ax2.set_xlabel("days since the campaign's first run")
    return svg(fig)


def _fig_speed(per_run: pl.DataFrame, speed: tuple[str, str]) -> str:
    """α and the largest drift against the run's speed (``speed``: its column and unit, the
    override % where every run's is known, else the 95th-percentile joint speed)."""
    col, unit = speed
    what = "override" if unit == "%" else "95th percentile joint speed"
    fig = figure(3.2)
    ax1, ax2 = fig.subplots(1, 2)
    s = per_run[col].fill_null(np.nan).to_numpy()
    a = per_run["alpha_per_k"].to_numpy() * 1e6
    lo = a - per_run["ci95_low"].to_numpy() * 1e6
    hi = per_run["ci95_high"].to_numpy() * 1e6 - a
    ax1.errorbar(s, a, yerr=[lo, hi], fmt="o", capsize=3)
    ax1.set_xlabel(f"speed ({unit}, {what})")
    ax1.set_ylabel("α (10⁻⁶/K), 95 %")
    ax2.plot(s, per_run["drift_um"].to_numpy(), "s")
    ax2.set_xlabel(f"speed ({unit})")
    ax2.set_ylabel("largest drift (µm)")
    return svg(fig)


def _group_table(groups: pl.DataFrame, what: str) -> Table:
    return Table(
        caption=f"Per {what}: α's mean and range over its runs; the drift envelope (the largest "
        "and the mean of the runs' largest drifts)",
        columns=[
            what,
            "runs",
            "α mean (10⁻⁶/K)",
            "α range",
            "largest drift (µm)",
            "mean largest drift (µm)",
        ],
        rows=[
            [
                str(g["group"]),
                str(g["runs"]),
                _f(g["alpha_mean"], 1e6),
                f"{_f(g['alpha_min'], 1e6)} – {_f(g['alpha_max'], 1e6)}",
                _f(g["drift_max_um"], 1.0, ".1f"),
                _f(g["drift_mean_um"], 1.0, ".1f"),
            ]
            for g in groups.iter_rows(named=True)
        ],
    )


def campaign_sections(summary_: CampaignSummary) -> list[Section]:
    """The page's sections from :func:`thermrs.campaigns.summary.campaign_summary`."""
    per_run, trend, odd, folds = (
        summary_.per_run, summary_.trend, summary_.standouts, summary_.folds
    )  # fmt: skip
    summary = Section("summary", "Summary")
    summary.blocks.append(Paragraph(f"Over time: {trend['sentence']}."))
    if odd:
        summary.blocks.append(
            Paragraph(
                "Runs that stand out: "
                + "; ".join(f"{o['recording']}#{o['run']} ({o['why']})" for o in odd)
                + "."
            )
        )
    else:
        summary.blocks.append(
            Paragraph(
                "No run stands out (α within 3 standard errors of the "
                "others', no drift far beyond theirs)."
            )
        )
    time = Section("time", "Over time")
    time.blocks.append(
        Figure(
            "campaign-time",
            "α per run with its 95 % interval against the day, the fitted "
            "trend; the largest drift of each run",
            _fig_time(per_run, trend),
        )
    )
    time.blocks.append(_group_table(summary_.by_day, "day"))
    speed = Section("speed", "By speed")
    speed.blocks.append(
        Figure(
            "campaign-speed",
            "α and the largest drift against each run's speed (the 95th "
            "percentile of its fastest joint's speed)",
            _fig_speed(per_run, summary_.speed),
        )
    )
    speed.blocks.append(_group_table(summary_.by_speed, "speed"))
    sections = [summary, time, speed, _runs_section(per_run)]
    if folds is not None:
        sections.append(_held_out_section(folds))
    return sections


def _runs_section(per_run: pl.DataFrame) -> Section:
    """Every run: its α, interval, rms and largest drift."""
    runs = Section("runs", "Every run")
    runs.blocks.append(
        Table(
            caption="α fitted on each run alone (time-series fit, 95 % interval) and the largest "
            "drift of a spot from its camera's first visit",
            columns=[
                "recording",
                "run",
                "date",
                "speed (%)",
                "speed (°/s)",
                "α (10⁻⁶/K)",
                "95 % interval",
                "rms (µm)",
                "largest drift (µm)",
            ],
            rows=[
                [
                    r["recording"],
                    r["run"],
                    str(r["date"]),
                    _f(r.get("speed_pct"), 1.0, ".0f"),
                    _f(r["speed_deg_s"], 1.0, ".0f"),
                    _f(r["alpha_per_k"], 1e6),
                    f"{_f(r['ci95_low'], 1e6)} – {_f(r['ci95_high'], 1e6)}",
                    _f(r["rms_um"]),
                    _f(r["drift_um"]),
                ]
                for r in per_run.iter_rows(named=True)
            ],
        )
    )
    return runs


def _held_out_section(folds: pl.DataFrame) -> Section:
    """The folds of a rule: α on their training runs, the rms on their held-out runs."""
    held = Section("held-out", "Held out by rule")
    held.blocks.append(
        Table(
            caption="α fitted on each fold's training runs; held-out rms: measured − "
            "predicted drift over every held-out visit (µm, the norm of u and v)",
            columns=[
                "fold",
                "training runs",
                "held-out runs",
                "α (10⁻⁶/K)",
                "held-out rms (µm)",
            ],
            rows=[
                [
                    f["fold"],
                    str(f["train_runs"]),
                    str(f["holdout_runs"]),
                    _f(f["alpha_per_k"], 1e6),
                    _f(f["holdout_rms_um"]),
                ]
                for f in folds.iter_rows(named=True)
            ],
        )
    )
    return held


def write_campaign_page(
    summary_: CampaignSummary, out: str | Path, *, title: str = "Campaign: α and drift per run"
) -> Path:
    """Write the page of a campaign's summary
    (:func:`thermrs.campaigns.summary.campaign_summary`) atomically: ``.html``
    (self-contained, figures inline) or ``.md`` (its figures as SVG files in ``OUT_files/``
    beside it)."""
    out = Path(out)
    sections = campaign_sections(summary_)
    now = datetime.datetime.now(datetime.UTC)
    meta = f"{summary_.per_run.height} runs; written {now:%Y-%m-%d %H:%M} UTC"
    if out.suffix == ".html":
        write_text(out, to_html(sections, title=title, meta=meta))
        return out
    fig_dir = out.with_name(f"{out.stem}_files")

    def fill(tmp: Path) -> None:
        text, _ = to_markdown(sections, title=title, meta=meta, fig_dir=tmp, rel=fig_dir.name)
        write_text(out, text)

    write_dir(fig_dir, fill)
    return out
