"""``thermrs predict``: runs' drift predicted from their temperatures."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import click

from thermrs.cli.common import (
    EXIT_DATA_LOSS,
    TRAIN_HELP,
    AlphaType,
    distinct_runs,
    input_file,
    out,
    rig_option,
    run_file,
    run_tables,
    runs_option,
    table,
    writable,
    write_csv,
    write_json,
)
from thermrs.errors import InputError


@click.command()
@rig_option
@runs_option("Runs to predict")
@click.option(
    "--alpha",
    "alpha",
    type=AlphaType(),
    default=None,
    help="α (1/K) to predict with: 23.2e-6, or 23.2u (×10⁻⁶); 0 < α < 1e-3.",
)
@click.option(
    "--fit",
    "fit_path",
    type=input_file,
    default=None,
    help="Take α from a `thermrs fit --json` file.",
)
@click.option(
    "--diagnosis",
    "diagnosis_path",
    type=input_file,
    default=None,
    help="Predict with α and the effect a `thermrs diagnose --json` file identified, and show "
    "the error before (nominal model) and after.",
)
@click.option(
    "--train",
    "train",
    multiple=True,
    type=run_file,
    help="Fit α on these runs first (time-series and start/end estimators). " + TRAIN_HELP,
)
@click.option(
    "--axis",
    type=click.Choice(["auto", "u", "v"]),
    default="auto",
    show_default=True,
    help="Chip axis of the end-of-run figures (auto: the larger predicted drift).",
)
@click.option(
    "--end-visits",
    type=click.IntRange(min=1),
    default=1,
    show_default=True,
    help="The run's end is the mean of its last N visits.",
)
@click.option(
    "--json",
    "json_path",
    type=click.Path(path_type=Path),
    default=None,
    help="Write the prediction table as JSON here (atomically).",
)
@click.option(
    "--series",
    "series_path",
    type=click.Path(path_type=Path),
    default=None,
    help="Write every visit's predicted and measured drift here (atomically): Parquet "
    "(.parquet) or CSV (.csv), by the name's suffix.",
)
def predict(
    rig_path: Path,
    runs: tuple[Path, ...],
    alpha: float | None,
    fit_path: Path | None,
    diagnosis_path: Path | None,
    train: tuple[Path, ...],
    axis: str,
    end_visits: int,
    json_path: Path | None,
    series_path: Path | None,
) -> None:
    """Predict runs' drift from their temperatures with the forward model and an α given,
    read from a fit, or fitted here on training runs; a Table 7-style table (predicted,
    measured, % error) with the whole series' agreement against the measurement's own noise.

    Exits 3 (after predicting) if part of a recording was lost.
    """
    from thermrs.ingest import write_parquet_atomic
    from thermrs.numbers import end_error
    from thermrs.predict import check_alpha, prediction_table
    from thermrs.predict import predict as run_predict
    from thermrs.rig import load_rig
    from thermrs.workflows import fit_document, training_alphas

    given = sum(x is not None and x != () for x in (alpha, fit_path, diagnosis_path, train))
    if given != 1:
        raise InputError("give exactly one of --alpha, --fit, --diagnosis or --train")
    writable(json_path, "--json")
    writable(series_path, "--series", suffixes=(".parquet", ".csv"))
    r = load_rig(rig_path)
    if diagnosis_path is not None:
        from thermrs.cli.compensate import predict_diagnosed

        predict_diagnosed(r, diagnosis_path, runs, json_path, series_path)
        return
    loss = False
    alphas: dict[str, float] = {}
    if alpha is not None:
        alphas["given"] = alpha
    elif fit_path is not None:
        try:
            doc = json.loads(fit_path.read_text())
            alphas["fit"] = check_alpha(doc["alpha_per_k"]["value"], what=f"--fit {fit_path}:")
        except FileNotFoundError:
            raise InputError(f"--fit {fit_path}: no such file") from None
        except (ValueError, KeyError, TypeError) as e:
            why = f"{type(e).__name__}: {e}".splitlines()[0]
            raise InputError(f"--fit {fit_path}: not a `thermrs fit --json` file ({why})") from None
    else:
        tables, loss = run_tables(train, r, "--train")
        alphas.update(training_alphas(fit_document(tables, r)))
    held, lost = run_tables(runs, r, "--run")
    loss |= lost
    if train:
        distinct_runs(tables, held, "--run")
    result = prediction_table(held, r, alphas=alphas, axis=axis, end_visits=end_visits)
    if json_path is not None:
        write_json(
            json_path, {"alpha_per_k": alphas, "table": result.drop("alpha_per_k").to_dicts()}
        )
    if series_path is not None:
        import polars as pl

        series = pl.concat(
            [
                run_predict(pl.concat(held, how="diagonal_relaxed"), r, alpha_per_k=a).select(
                    pl.lit(label).alias("alpha"), pl.all()
                )
                for label, a in alphas.items()
            ]
        )
        if series_path.name.endswith(".csv"):
            write_csv(series_path, series)
        else:
            write_parquet_atomic(series, series_path)
    t = table(
        "Predicted against measured drift at the end of each run",
        [
            (c, "left" if c in ("α", "cam", "run", "axis") else "right")
            for c in (
                "α",
                "cam",
                "run",
                "axis",
                "pred µm",
                "meas µm",
                "err %",
                "rms µm",
                "noise µm",
            )
        ],
        caption="α (×10⁻⁶/K): "
        + ", ".join(f"{k} {v * 1e6:.3f}" for k, v in alphas.items())
        + (" (series: time-series fit; A, B, mean: start/end)" if train else ""),
    )
    for row in result.iter_rows(named=True):
        t.add_row(
            row["alpha"],
            row["camera"],
            row["run"],
            row["axis"],
            f"{row['predicted_um']:.2f}",
            f"{row['measured_um']:.2f}",
            end_error(row["predicted_um"], row["measured_um"], row["noise_um"], suffix=""),
            f"{row['rms_centred_um']:.3f}",
            f"{row['noise_um']:.3f}",
        )
    out.print(t)
    out.print(
        "rms: prediction against measurement over every visit, both axes, mean offset removed; "
        "noise: the measurement's own visit-to-visit noise."
    )
    if loss:
        sys.exit(EXIT_DATA_LOSS)
