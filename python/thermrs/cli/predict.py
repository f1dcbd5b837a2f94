"""``thermrs predict``: runs' drift predicted from their temperatures."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

import click

from thermrs.cli.common import (
    EXIT_DATA_LOSS,
    TRAIN_HELP,
    AlphaType,
    campaign_options,
    chosen_runs,
    chosen_splits,
    input_file,
    json_option,
    out,
    rig_option,
    run_file,
    runs_option,
    table,
    writable,
    write_csv,
    write_json,
)
from thermrs.errors import InputError

if TYPE_CHECKING:  # pragma: no cover
    from thermrs.analyses.inputs import Split
    from thermrs.analyses.predict import Prediction


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
    help="Fit α on these runs first (time-series and start/end estimators). "
    + TRAIN_HELP
    + " With --campaign: runs of the dataset (RECORDING#RUN); --run defaults to the others.",
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
@json_option(
    "Write the prediction table as JSON here (atomically); with --rule, one per fold "
    '({"rule", "folds": [{"fold", "train", "holdout", "alpha_per_k", "table"}]}).'
)
@click.option(
    "--series",
    "series_path",
    type=click.Path(path_type=Path),
    default=None,
    help="Write every visit's predicted and measured drift here (atomically): Parquet "
    "(.parquet) or CSV (.csv), by the name's suffix; with --rule, a fold column first.",
)
@campaign_options(
    rule="With --campaign: for each fold, fit α on its training runs and predict its held-out "
    "runs (a table per fold, then a summary of the folds)."
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
    campaign_path: Path | None,
    query: str | None,
    rule: str | None,
) -> None:
    """Predict runs' drift from their temperatures with the forward model and an α given,
    read from a fit, or fitted here on training runs; a Table 7-style table (predicted,
    measured, % error) with the whole series' agreement against the measurement's own noise.

    Exits 3 (after predicting) if part of a recording was lost.
    """
    from thermrs.analyses.inputs import Split
    from thermrs.analyses.predict import predict_splits
    from thermrs.rig import load_rig

    training = bool(train) or rule is not None
    given = sum(
        x for x in (alpha is not None, fit_path is not None, diagnosis_path is not None, training)
    )
    if given != 1:
        raise InputError(
            "give exactly one of --alpha, --fit, --diagnosis or --train (or --rule with --campaign)"
        )
    writable(json_path, "--json")
    writable(series_path, "--series", suffixes=(".parquet", ".csv"))
    alphas = None if training or diagnosis_path else _given_alpha(alpha, fit_path)
    r = load_rig(rig_path)
    if training:
        sets = chosen_splits(campaign_path, query, rule, train, runs, r, holdout_what="--run")
    else:
        held, lost = chosen_runs(campaign_path, query, runs, r, "--run")
        sets = [Split("", [], held, lost)]
    if diagnosis_path is not None:
        _diagnosed(r, diagnosis_path, sets[0], json_path, series_path)
        return
    preds = predict_splits(sets, r, alphas=alphas, axis=axis, end_visits=end_visits)
    _write(preds, rule, json_path, series_path)
    for p in preds:
        _render(p, training)
    out.print(
        "rms: prediction against measurement over every visit, both axes, mean offset removed; "
        "noise: the measurement's own visit-to-visit noise."
    )
    if rule is not None:
        _render_folds(preds, rule)
    if any(s.data_loss for s in sets):
        sys.exit(EXIT_DATA_LOSS)


def _diagnosed(
    r: Any, diagnosis: Path, s: Split, json_path: Path | None, series_path: Path | None
) -> None:
    """``thermrs predict --diagnosis D.json --run RUN…``: the held-out error before (nominal
    model) and after (α and the identified effect), per run and camera."""
    from thermrs.analyses.predict import predict_diagnosed
    from thermrs.cli.common import say_model
    from thermrs.ingest import write_parquet_atomic

    p = predict_diagnosed(s.holdout, r, diagnosis)
    say_model(p.model)
    if json_path is not None:
        write_json(json_path, p.to_json())
    if series_path is not None:
        if series_path.name.endswith(".csv"):
            write_csv(series_path, p.series)
        else:
            write_parquet_atomic(p.series, series_path)
    promised = p.model.promised_shrink
    t = table(
        "Held-out error before (nominal model) and after (the diagnosed effect)",
        [(c, "left" if c in ("run", "cam") else "right")
         for c in ("run", "cam", "before rms µm", "after rms µm", "shrink", "visits")],
        caption="rms: measured − predicted drift over every visit, both axes, each series' "
        "mean removed"
        + (f"; the diagnosis promised {promised:.0%}" if promised is not None else ""),
    )  # fmt: skip
    for row in p.shrink.iter_rows(named=True):
        t.add_row(row["run"], row["camera"], f"{row['nominal_rms_um']:.3f}",
                  f"{row['diagnosed_rms_um']:.3f}", f"{row['shrink']:.0%}",
                  str(row["n_visits"]))  # fmt: skip
    out.print(t)
    if s.data_loss:
        sys.exit(EXIT_DATA_LOSS)


def _given_alpha(alpha: float | None, fit_path: Path | None) -> dict[str, float]:
    """α given, or read from a `thermrs fit --json` file."""
    from thermrs.analyses.predict import read_fit_alpha

    if alpha is not None:
        return {"given": alpha}
    assert fit_path is not None
    return {"fit": read_fit_alpha(fit_path)}


def _write(
    preds: list[Prediction], rule: str | None, json_path: Path | None, series_path: Path | None
) -> None:
    """The JSON document and the series file: one prediction as ever; folds of a rule each."""
    import polars as pl

    from thermrs.ingest import write_parquet_atomic

    if json_path is not None:
        if rule is None:
            doc = {k: v for k, v in preds[0].to_json().items() if k in ("alpha_per_k", "table")}
        else:
            from thermrs.analyses.predict import predict_synthesis

            doc = {
                "rule": rule,
                "folds": [p.to_json() for p in preds],
                "synthesis": predict_synthesis(preds),
            }
        write_json(json_path, doc)
    if series_path is not None:
        series = pl.concat(
            [
                p.series
                if rule is None
                else p.series.select(pl.lit(p.split.name).alias("fold"), pl.all())
                for p in preds
            ]
        )
        if series_path.name.endswith(".csv"):
            write_csv(series_path, series)
        else:
            write_parquet_atomic(series, series_path)


def _alpha_caption(p: Prediction, training: bool) -> str:
    """The α values of the table's rows, and where each comes from (this rig's cameras)."""
    used = set(p.table["alpha"].to_list()) if "alpha" in p.table.columns else set(p.alphas)
    shown = {k: v for k, v in p.alphas.items() if k in used} or dict(p.alphas)
    text = "α (×10⁻⁶/K): " + ", ".join(f"{k} {v * 1e6:.3f}" for k, v in shown.items())
    if not training:
        return text
    start_end = [k for k in shown if k != "series"]
    said = ["series: time-series fit"] if "series" in shown else []
    if start_end:
        said.append(f"{', '.join(start_end)}: start/end")
    return text + (f" ({'; '.join(said)})" if said else "")


def _render(p: Prediction, training: bool) -> None:
    """One split's Table 7-style table."""
    from thermrs.numbers import end_error

    t = table(
        (f"{p.split.name}: p" if p.split.name else "P")
        + "redicted against measured drift at the end of each run",
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
        caption=_alpha_caption(p, training),
    )
    for row in p.table.iter_rows(named=True):
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


def _render_folds(preds: list[Prediction], rule: str) -> None:
    """The folds of a rule side by side: α fitted on each, the error on its held-out runs."""
    t = table(
        f"Held out by fold ({rule})",
        [
            ("fold", "left"),
            ("train runs", "right"),
            ("held-out runs", "right"),
            ("α series (×10⁻⁶/K)", "right"),
            ("held-out rms µm", "right"),
        ],
        caption="held-out rms: measured − predicted drift over every held-out visit and both "
        "chip axes, each series' mean offset removed (the per-run rms above, pooled), with the "
        "time-series α",
    )
    for p in preds:
        t.add_row(
            p.split.name,
            str(len(p.split.train)),
            str(len(p.split.holdout)),
            f"{p.alphas['series'] * 1e6:.3f}",
            f"{p.rms_um():.3f}",
        )
    out.print(t)
    from thermrs.analyses.predict import predict_synthesis

    out.print(f"Across the folds: {predict_synthesis(preds)['sentence']}.")
