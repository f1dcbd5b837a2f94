"""The campaign page (:mod:`thermrs.report.campaign_page`), under the name campaigns have
always used: α and drift per run against date and speed, a trend test over time, per-day and
per-speed summaries, runs that stand out, the held-out check of a rule."""

from __future__ import annotations

from pathlib import Path

import polars as pl

__all__ = ["write_page"]


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
        ``.md`` (Markdown, its figures in ``OUT_files/``) or ``.html`` (self-contained).
    folds
        :func:`thermrs.campaigns.summary.holdout_by_rule`, if a rule was asked for.
    title
        The page's title.
    """
    from thermrs.report.campaign_page import write_campaign_page

    return write_campaign_page(per_run, out, folds=folds, title=title)
