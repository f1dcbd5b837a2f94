"""``thermrs compensate``: the diagnosed model as a compensation law. Parses and renders;
:mod:`thermrs.compensate` computes."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import click

from thermrs.cli.common import (
    input_file,
    out,
    rig_option,
    say_model,
    table,
    writable,
    write_csv,
    write_json,
)

if TYPE_CHECKING:  # pragma: no cover
    pass

__all__ = ["compensate"]


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
    help="Held-out runs (FILE or FILE#RUN; --check A B or repeats) to check the law on: their "
    "rms with "
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
@click.option(
    "--model",
    type=click.Choice(["diagnosed", "baseline"]),
    default="diagnosed",
    show_default=True,
    help="baseline: export instead the linear regression of `diagnose --baselines` with the "
    "least held-out rms (its coefficients with 95 % intervals and the temperature range it was "
    "fitted on; --check warns where a run leaves that range).",
)
def compensate(
    rig_path: Path,
    diagnosis: Path,
    out_path: Path,
    check: tuple[Path, ...],
    span_k: float,
    model: str,
) -> None:
    """Export the diagnosed model as a compensation law: per taught pose (camera) and chip
    axis, the drift as a function of the measured temperatures, µm per kelvin above the rig's
    reference temperature, with 95 % intervals, plus the chip and time terms of the effect
    (fixture, sensor drift, lag); a robot controller or a CMM program applies it.
    """
    from thermrs.cli.common import file_tables
    from thermrs.compensate import compensation_law, load_diagnosis
    from thermrs.rig import load_rig

    writable(out_path, "-o", suffixes=(".csv", ".json"))
    r = load_rig(rig_path)
    if model == "baseline":
        from thermrs.cli.baselines import compensate_baseline

        compensate_baseline(r, diagnosis, out_path, check)
        return
    dm = load_diagnosis(diagnosis, r)
    say_model(dm)
    law = compensation_law(r, dm, span_k=span_k)
    checked = None
    if check:
        held, _ = file_tables(check, r, "--check")
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
        inside = {
            True: "inside the promised range",
            False: "OUTSIDE the promised range",
            None: "the diagnosis promised no range",
        }
        out.print(
            f"Over the check runs: {a['compensated_rms_um']:.2f} µm rms compensated, "
            f"{inside[a['inside']]}."
        )
    click.echo(f"wrote {out_path}", err=True)
