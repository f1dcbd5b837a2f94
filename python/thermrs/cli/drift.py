"""``thermrs drift``: heating curves and ISO 9283-style figures."""

from __future__ import annotations

import sys
from pathlib import Path

import click

from thermrs.cli.common import (
    EXIT_DATA_LOSS,
    campaign_options,
    chosen_runs,
    json_option,
    out,
    rig_option,
    runs_option,
    table,
    writable,
    write_json,
)
from thermrs.defaults import ISO_TOLERANCE_UM, ISO_WINDOW


@click.command()
@rig_option
@runs_option("Runs")
@click.option(
    "--window",
    type=click.IntRange(min=3),
    default=ISO_WINDOW,
    show_default=True,
    help="Visits per ISO 9283 window.",
)
@click.option(
    "--tolerance-um",
    type=click.FloatRange(min=0, min_open=True),
    default=ISO_TOLERANCE_UM,
    show_default=True,
    help="Settling tolerance of the barycentre (µm).",
)
@json_option("Write the curves and the ISO 9283-style figures as JSON here (atomically).")
@campaign_options()
def drift(
    rig_path: Path, runs: tuple[Path, ...], window: int, tolerance_um: float,
    json_path: Path | None, campaign_path: Path | None, query: str | None,
) -> None:  # fmt: skip
    """How runs warm up and drift: first-order heating curves y = y₀ + A·e^(−t/τ) per ROI
    temperature and per camera drift axis, and ISO 9283-style pose figures per camera chip
    (RP cold and warm, dAP, dRP, settling time). The runs are files, or runs of a --campaign
    dataset.

    Exits 3 (after reporting) if part of a recording was lost.
    """
    from thermrs.analyses.drift import drift_tables
    from thermrs.iso9283 import LABEL
    from thermrs.rig import load_rig

    writable(json_path, "--json")
    r = load_rig(rig_path)
    tables, loss = chosen_runs(campaign_path, query, runs, r, "--run")
    res = drift_tables(tables, window=window, tolerance_um=tolerance_um)
    curves, iso = res.curves, res.iso
    if json_path is not None:
        write_json(json_path, res.to_json())

    from thermrs.numbers import fmt as num
    from thermrs.numbers import tau_determined

    t = table(
        "Heating curves y = y₀ + A·e^(−t/τ)",
        [
            (c, "left" if c in ("run", "series", "phase") else "right")
            for c in ("run", "series", "y₀", "A", "τ (min)", "± τ", "rms", "phase")
        ],
    )
    for row in curves.iter_rows(named=True):
        series = (
            row["series"]
            if row["kind"] == "temperature"
            else (f"drift {row['camera']} {row['axis']} (µm)")
        )
        unit = " °C" if row["kind"] == "temperature" else ""
        if row["phase"] is not None and not tau_determined(row["tau_min"], row["tau_min_se"]):
            t.add_row(row["run"], series + unit, "", "", "", "", "",
                      "no heating curve: τ not determined")  # fmt: skip
            continue
        t.add_row(
            row["run"], series + unit, num(row["y0"]), num(row["a"]), num(row["tau_min"], 1),
            num(row["tau_min_se"], 1), num(row["rms"], 3), row["phase"] or "no fit (--json: why)",
        )  # fmt: skip
    out.print(t)
    t = table(
        LABEL,
        [
            (c, "left" if c in ("run", "cam") else "right")
            for c in ("run", "cam", "RP cold µm", "RP warm µm", "dAP µm", "dRP µm", "settle min")
        ],
    )
    for row in iso.summary.iter_rows(named=True):
        t.add_row(
            row["run"], row["camera"], num(row["rp_cold_um"]), num(row["rp_warm_um"]),
            num(row["dap_um"]), num(row["drp_um"]), num(row["settle_min"], 1),
        )  # fmt: skip
    out.print(t)
    if loss:
        sys.exit(EXIT_DATA_LOSS)
