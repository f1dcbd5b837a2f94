"""``thermrs compensate`` and ``thermrs predict --diagnosis``: the diagnosed model put to use.
Parses and renders; :mod:`thermrs.compensate` computes."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import TYPE_CHECKING

import click

from thermrs.cli.common import (
    EXIT_DATA_LOSS,
    input_file,
    out,
    rig_option,
    table,
    writable,
    write_csv,
    write_json,
)

if TYPE_CHECKING:  # pragma: no cover
    import polars as pl

    from thermrs.compensate import DiagnosedModel
    from thermrs.rig import Rig

__all__ = ["compensate", "predict_diagnosed"]


def _say_model(m: DiagnosedModel) -> None:
    effects = ", ".join(
        e.name + " " + ", ".join(f"{k}={v}" for k, v in e.to_dict().items() if k != "name")
        for e in m.effects
    )
    click.echo(
        f"thermrs: diagnosis {m.status}: α {m.alpha_per_k * 1e6:.3f}×10⁻⁶/K"
        + (f" with {effects}" if effects else "")
        + (
            f"; it promised a held-out shrink of {m.promised_shrink:.0%}"
            if m.promised_shrink is not None
            else ""
        ),
        err=True,
    )
    if m.note:
        click.echo(f"thermrs: warning: {m.note}", err=True)


def predict_diagnosed(
    r: Rig,
    diagnosis: Path,
    held: list[pl.DataFrame],
    loss: bool,
    json_path: Path | None,
    series_path: Path | None,
) -> None:
    """``thermrs predict --diagnosis D.json --run RUN…``: the held-out error before (nominal
    model) and after (α and the identified effect), per run and camera."""
    from thermrs.compensate import load_diagnosis, predict_series, shrink_table
    from thermrs.ingest import write_parquet_atomic

    model = load_diagnosis(diagnosis, r)
    _say_model(model)
    series = predict_series(held, r, model)
    shrink = shrink_table(series)
    if json_path is not None:
        write_json(
            json_path,
            {
                "alpha_per_k": {
                    "nominal": model.nominal_alpha_per_k,
                    "diagnosed": model.alpha_per_k,
                },
                "effects": [e.to_dict() for e in model.effects],
                "promised_shrink": model.promised_shrink,
                "table": shrink.to_dicts(),
            },
        )
    if series_path is not None:
        if series_path.name.endswith(".csv"):
            write_csv(series_path, series)
        else:
            write_parquet_atomic(series, series_path)
    t = table(
        "Held-out error before (nominal model) and after (the diagnosed effect)",
        [(c, "left" if c in ("run", "cam") else "right")
         for c in ("run", "cam", "before rms µm", "after rms µm", "shrink", "visits")],
        caption="rms: measured − predicted drift over every visit, both axes, each series' "
        "mean removed"
        + (f"; the diagnosis promised {model.promised_shrink:.0%}"
           if model.promised_shrink is not None else ""),
    )  # fmt: skip
    for row in shrink.iter_rows(named=True):
        t.add_row(row["run"], row["camera"], f"{row['nominal_rms_um']:.3f}",
                  f"{row['diagnosed_rms_um']:.3f}", f"{row['shrink']:.0%}",
                  str(row["n_visits"]))  # fmt: skip
    out.print(t)
    if loss:
        sys.exit(EXIT_DATA_LOSS)


@click.command()
@rig_option
@click.option(
    "--diagnosis",
    "diagnosis",
    required=True,
    type=input_file,
    help="A `thermrs diagnose --json` file: α and the effect it identified.",
)
@click.option(
    "-o",
    "--out",
    "out_path",
    required=True,
    type=click.Path(path_type=Path),
    help="The law to write (atomically): CSV (.csv, one self-contained row per pose and chip "
    "axis: the reference temperature, a µm/K column per temperature name with its 95 % "
    "interval, the chip and time terms) or JSON "
    "(.json, with the model and the diagnosis' promise).",
)
@click.option(
    "--check",
    "check",
    multiple=True,
    type=click.Path(path_type=Path),
    metavar="RUN",
    help="Held-out runs (FILE or FILE#RUN, repeatable) to check the law on: their rms with "
    "the law against the nominal model's and against the range the diagnosis promised.",
)
@click.option(
    "--span-k",
    type=click.FloatRange(min=0, min_open=True, max=200),
    default=20.0,
    show_default=True,
    help="Temperature rise above the rig's reference over which slopes are taken and "
    "linearity checked (K).",
)
def compensate(
    rig_path: Path, diagnosis: Path, out_path: Path, check: tuple[Path, ...], span_k: float
) -> None:
    """Export the diagnosed model as a compensation law: per taught pose (camera) and chip
    axis, the drift as a function of the measured temperatures, µm per kelvin above the rig's
    reference temperature, with 95 % intervals, plus the chip and time terms of the effect
    (fixture, sensor drift, lag); a robot controller or a CMM program applies it.
    """
    from thermrs.cli.common import run_tables
    from thermrs.compensate import compensation_law, load_diagnosis
    from thermrs.rig import load_rig

    writable(out_path, "-o", suffixes=(".csv", ".json"))
    r = load_rig(rig_path)
    model = load_diagnosis(diagnosis, r)
    _say_model(model)
    law = compensation_law(r, model, span_k=span_k)
    checked = None
    if check:
        held, _ = run_tables(check, r, "--check")
        checked = law.check(held, r)
    if out_path.name.endswith(".csv"):
        write_csv(out_path, law.wide())
    else:
        write_json(out_path, {**law.to_json(), "check": checked})
    t = table(
        f"Compensation law: drift (µm) = Σ coefficient × (T − {law.reference_c:g} °C)",
        [(c, "left" if c in ("pose", "axis", "term", "unit") else "right")
         for c in ("pose", "axis", "term", "coefficient", "95 % interval", "unit")],
        caption=f"linear to {law.linearity_um:.3f} µm over {span_k:g} K; "
        + (f"a compensated pose keeps {law.residual_um:.2f} µm rms (held-out, the diagnosis)"
           if law.residual_um is not None else ""),
    )  # fmt: skip
    for row in law.table.iter_rows(named=True):
        t.add_row(row["pose"], row["axis"], row["term"], f"{row['coefficient']:.4g}",
                  f"{row['ci95_low']:.4g} – {row['ci95_high']:.4g}", row["unit"])  # fmt: skip
    out.print(t)
    if law.model.holdout_rms_after_ci95 is not None:
        lo, hi = law.model.holdout_rms_after_ci95
        out.print(
            f"Promised: a compensated held-out run like the diagnosis' keeps {lo:.2f}–{hi:.2f} µm "
            "rms (95 %)."
        )
    if checked is not None:
        for row in checked["runs"]:
            out.print(
                f"Check on {row['run']}: nominal {row['nominal_rms_um']:.2f} µm → compensated "
                f"{row['compensated_rms_um']:.2f} µm rms."
            )
        a = checked["all"]
        inside = {True: "inside", False: "OUTSIDE", None: "no range was promised for"}
        out.print(
            f"Over the check runs: {a['compensated_rms_um']:.2f} µm rms compensated, "
            f"{inside[a['inside']]} the promised range."
        )
    click.echo(f"wrote {out_path}", err=True)
