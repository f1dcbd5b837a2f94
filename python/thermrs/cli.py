"""The ``thermrs`` command line: a thin layer over the library API.

Exit codes (SPEC §7): 0 success; 2 bad input or usage (one line on stderr, no traceback);
3 finished with data loss; 1 internal error (set ``THERMRS_DEBUG=1`` for the traceback).
"""

from __future__ import annotations

import json
import os
import sys
import time
import traceback
from collections.abc import Callable
from pathlib import Path
from typing import Any

import click
from rich.console import Console
from rich.table import Table

from thermrs import paper as paper_mod
from thermrs.errors import InputError, ThermrsError
from thermrs.rig import default_rig_path, load_rig
from thermrs.visits import DEFAULT_TOLERANCE_DEG

EXIT_OK, EXIT_INTERNAL, EXIT_BAD_INPUT, EXIT_DATA_LOSS = 0, 1, 2, 3

out = Console(highlight=False)

#: ``--rig RIG``, shared by the commands that read recordings.
rig_option = click.option(
    "--rig", "rig_path", required=True, type=click.Path(path_type=Path), help="Rig file."
)


def out_option(what: str) -> Callable[[Callable[..., Any]], Callable[..., Any]]:
    """``-o/--out PATH`` with its help text."""
    return click.option(
        "-o", "--out", "out_path", required=True, type=click.Path(path_type=Path), help=what
    )


def _fmt(x: float | None, digits: int = 2) -> str:
    return "—" if x is None else f"{x:.{digits}f}"


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="thermrs")
def cli() -> None:
    """Measure, model and predict the temperature-induced drift of industrial robots."""


@cli.command()
@click.option("--json", "as_json", is_flag=True, help="Print SPEC §7 JSON instead of tables.")
@click.option("--train-run", default=1, show_default=True, help="Run whose drift fits α.")
@click.option(
    "--exact",
    is_flag=True,
    help="Carry full precision instead of the paper's rounding to 0.01.",
)
def paper(as_json: bool, train_run: int, exact: bool) -> None:
    """Reproduce the KR 15/2 paper's Tables 6 and 7 (Eq. 1–3)."""
    data = paper_mod.load_paper_data()
    rounding = not exact
    fm_alpha, fm_table = paper_mod.forward_model_table(train_run=train_run, data=data)
    if as_json:
        doc = paper_mod.to_json(train_run=train_run, data=data, paper_rounding=rounding)
        doc["forward_model"] = {"alpha": fm_alpha, "table7": fm_table.to_dicts()}
        click.echo(json.dumps(doc, indent=2))
        return
    printed = data.printed if train_run == 1 else {}
    p6 = printed.get("table6", {})
    t6 = Table(title=f"Table 6 — α from Run {train_run} (×10⁻⁶ /°C)")
    for col in ("α", "thermrs", "paper", "Δ"):
        t6.add_column(col, justify="right" if col != "α" else "left")
    for row in paper_mod.table6(train_run=train_run, data=data, paper_rounding=rounding).iter_rows(
        named=True
    ):
        mine = row["alpha_per_k"] * 1e6
        theirs = p6.get(row["alpha"])
        t6.add_row(
            f"α_{row['alpha']}",
            _fmt(mine, 2 if rounding else 4),
            _fmt(theirs),
            _fmt(None if theirs is None else mine - theirs, 3),
        )
    if "alpha_6061_t6" in p6:
        t6.add_row("α_6061-T6 (handbook)", "", _fmt(p6["alpha_6061_t6"]), "")
    out.print(t6)

    p7 = {(r["alpha"], r["camera"]): r for r in printed.get("table7", [])}
    t7 = Table(title="Table 7 — predicted vs measured Δl_x (µm), error (%)")
    for col in (
        "α",
        "camera",
        "run",
        "predicted",
        "measured",
        "error %",
        "paper pred.",
        "paper meas.",
        "paper err.",
    ):
        t7.add_column(col, justify="left" if col in ("α", "camera") else "right")
    for r in paper_mod.table7(train_run=train_run, data=data, paper_rounding=rounding).iter_rows(
        named=True
    ):
        ref = p7.get((r["alpha"], r["camera"]), {}).get(f"run{r['run']}", {})
        t7.add_row(
            f"α_{r['alpha']}",
            r["camera"],
            str(r["run"]),
            _fmt(r["predicted_um"]),
            _fmt(r["measured_um"]),
            _fmt(r["error_pct"]),
            _fmt(ref.get("predicted_um")),
            _fmt(ref.get("measured_um")),
            _fmt(ref.get("error_pct")),
        )
    out.print(t7)
    tf = Table(
        title=(
            "Generalised — the same protocol through the SPEC §4 forward model "
            "(embedded rig; drift along the chip y axis)"
        )
    )
    for col in ("α", "α (×10⁻⁶/°C)", "camera", "run", "predicted", "measured", "error %"):
        tf.add_column(col, justify="left" if col in ("α", "camera") else "right")
    for r in fm_table.iter_rows(named=True):
        tf.add_row(
            f"α_{r['alpha']}",
            _fmt(fm_alpha[r["alpha"]] * 1e6),
            r["camera"],
            str(r["run"]),
            _fmt(r["predicted_um"]),
            _fmt(r["measured_um"]),
            _fmt(r["error_pct"]),
        )
    out.print(tf)
    if rounding:
        out.print(
            "[dim]Paper's arithmetic: α rounded to 0.01×10⁻⁶, drifts to 0.01 µm before the % "
            "error. Run 2 measured values include the paper's +1 °C start adjustment.[/dim]"
        )
    out.print(
        "[dim]Forward model: link temperatures from Table 4 drive the rig's mapped lengths "
        "(a2←link2, d4←link3); measured = raw Table 4 drift. At poses A and B the forearm (d4) "
        "stands nearly vertical, so link 3 moves the spot along the chip x axis, not y: the "
        "rig's geometry needs about twice the paper's α to explain the y drift.[/dim]"
    )


@cli.command()
@click.argument("rig_path", required=False, type=click.Path(path_type=Path))
@click.option("--json", "as_json", is_flag=True, help="Print SPEC §7 JSON instead of tables.")
def rig(rig_path: Path | None, as_json: bool) -> None:
    """Check and explain a rig file (default: the embedded paper rig).

    Per pose: the flange position and, for every camera, where the laser meets its chip and
    at what incidence. Exits 2 if the laser misses a pose's own camera.
    """
    r = load_rig(rig_path)
    view = r.check()
    if as_json:
        doc = {"poses": view["poses"]}
        click.echo(json.dumps(doc, indent=2))
        return
    out.print(f"[bold]{r.name or r.model}[/bold]  ({rig_path or default_rig_path()})")
    out.print(
        f"robot {r.model}; cameras {', '.join(c.name for c in r.cameras)}; "
        f"α = {r.alpha_per_k:.3g} /K at {r.reference_c:g} °C; expanding "
        + ", ".join(f"{m.name}←{m.temperature}" for m in r.lengths)
    )
    for pose_name, p in view["poses"].items():
        x, y, z = p["flange_mm"]
        t = Table(
            title=(
                f"Pose {pose_name}: flange ({x:.2f}, {y:.2f}, {z:.2f}) mm, "
                f"elevation {p['elevation_deg']:.2f}°, azimuth {p['azimuth_deg']:.2f}°"
            )
        )
        for col in ("camera", "spot x (px)", "spot y (px)", "incidence (°)", "distance (mm)", ""):
            t.add_column(col, justify="left" if col in ("camera", "") else "right")
        for cam, spot in p["spot_px"].items():
            own = r.camera(cam).pose == pose_name
            inc = p["incidence_deg"][cam]
            dist = p["distance_mm"][cam]
            t.add_row(
                cam,
                _fmt(spot[0], 3) if spot else "misses",
                _fmt(spot[1], 3) if spot else "",
                _fmt(inc, 4),
                _fmt(dist, 3),
                "taught for this pose" if own else "",
            )
        out.print(t)


@cli.command()
@click.argument("recording", type=click.Path(path_type=Path))
@rig_option
@out_option("Frames Parquet; visits, temperatures and joints are written beside it.")
@click.option(
    "--visit-tolerance-deg",
    default=DEFAULT_TOLERANCE_DEG,
    show_default=True,
    help="Joint tolerance (°) for a spot frame to count as at its camera's pose.",
)
@click.option("--quiet", is_flag=True, help="No progress bar or summary.")
def extract(
    recording: Path, rig_path: Path, out_path: Path, visit_tolerance_deg: float, quiet: bool
) -> None:
    """Extract a recording into Parquet tables: frames (spot centroids), visits,
    temperatures (thermal ROI maxima and ambient) and joints.

    Exits 3 (after writing every table) if part of the recording was lost: a file cut short,
    a corrupt chunk.
    """
    from rich.progress import (
        BarColumn,
        DownloadColumn,
        Progress,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )

    from thermrs.ingest import extract as run_extract

    r = load_rig(rig_path)
    err = Console(stderr=True, highlight=False)
    with Progress(
        TextColumn("[bold]extract[/bold]"),
        BarColumn(),
        DownloadColumn(),
        TextColumn("{task.fields[fps]}"),
        TimeElapsedColumn(),
        TimeRemainingColumn(),
        console=err,
        disable=quiet,
        transient=True,
    ) as bar:
        task = bar.add_task("extract", total=None, fps="")
        t0 = time.perf_counter()

        def on_progress(done: int, total: int, frames: int) -> None:
            dt = max(time.perf_counter() - t0, 1e-9)
            bar.update(task, completed=done, total=total, fps=f"{frames / dt:,.0f} frames/s")

        ex = run_extract(
            recording, r, progress=on_progress, visit_tolerance_deg=visit_tolerance_deg
        )
        elapsed = time.perf_counter() - t0
    paths = ex.write(out_path)
    rep = ex.report
    if not quiet:
        n = ex.frames.height
        err.print(
            f"{n:,} frames in {elapsed:.2f} s ({n / max(elapsed, 1e-9):,.0f} frames/s), "
            f"{ex.visits.height} visits, "
            f"{ex.temperatures.height:,} temperature rows, {ex.joints.height:,} joint states"
        )
        t = Table(title="Frames by status")
        t.add_column("status")
        t.add_column("frames", justify="right")
        for k, v in rep.frames_by_status.items():
            t.add_row(k, f"{v:,}")
        err.print(t)
        if rep.skipped:
            s = Table(title="Skipped messages")
            s.add_column("topic: reason (first seen)")
            s.add_column("count", justify="right")
            for k, v in rep.skipped.items():
                s.add_row(rep.skipped_examples.get(k, k), f"{v:,}")
            err.print(s)
        for loss in rep.losses:
            err.print(f"[red]data loss[/red]: {loss['detail']}")
        if rep.recovered_messages:
            err.print(f"recovered {rep.recovered_messages} complete messages from the cut chunk")
        for name, p in paths.items():
            err.print(f"wrote {name}: {p}")
    if rep.data_loss:
        sys.exit(EXIT_DATA_LOSS)


@cli.command()
@rig_option
@click.option(
    "--scenario",
    "scenario_path",
    required=True,
    type=click.Path(path_type=Path),
    help="Scenario file (thermrs-scenario/1).",
)
@out_option("Recording to write (MCAP); the truth is written beside it.")
@click.option("--seed", type=int, default=None, help="Override the scenario's seed.")
def simulate(rig_path: Path, scenario_path: Path, out_path: Path, seed: int | None) -> None:
    """Simulate a rig at work: write a recording in the rig's own format and its truth
    (OUT.truth.parquet, OUT.truth-samples.parquet, OUT.truth.json)."""
    from thermrs.simulate import simulate as run_simulate

    r = load_rig(rig_path)
    t0 = time.perf_counter()
    sim = run_simulate(r, scenario_path, out_path, seed=seed)
    dt = time.perf_counter() - t0
    err = Console(stderr=True, highlight=False)
    size = sim.recording.stat().st_size / 1e6
    err.print(
        f"wrote {sim.recording} ({size:,.1f} MB): {sim.frames.height:,} CCD frames, "
        f"{sim.samples.height:,} thermal samples in {dt:.1f} s"
    )


def _write_json(path: Path, doc: object) -> None:
    """Write ``doc`` as JSON to ``path`` atomically."""
    from thermrs.ingest import atomic_tmp, publish

    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = atomic_tmp(path)
    try:
        tmp.write_text(json.dumps(doc, indent=2))
        publish(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


#: Files read by this process's command, by path: `predict --train rec#run1 --run rec#run2`
#: extracts `rec` once.
_FILES: dict[Any, Any] = {}


def _run_tables(paths: tuple[Path, ...], rig: Any, what: str) -> tuple[list[Any], bool]:
    """Run tables of recordings or extracted tables (``FILE`` or ``FILE#RUN``), and whether
    any recording lost data; lists the runs found in each file on stderr."""
    from thermrs.runs import load_runs, split_run_spec

    tables, loss = [], False
    files = {split_run_spec(p)[0] for p in paths}
    names = [f.name for f in files]
    for p in paths:
        # Two files of one name in different folders: name the runs by their paths.
        base = split_run_spec(p)[0]
        rt = load_runs(p, rig, name=str(base) if names.count(base.name) > 1 else None, cache=_FILES)
        click.echo(f"thermrs: {what} {rt.describe()}", err=True)
        for t in rt.tables:
            if t.height == 0:
                raise InputError(f"{what} {p}: no visit with a spot")
        if rt.data_loss:
            click.echo(f"thermrs: warning: {p}: part of the recording was lost", err=True)
        tables.extend(rt.tables)
        loss |= rt.data_loss
    return tables, loss


def runs_option(what: str) -> Callable[[Callable[..., Any]], Callable[..., Any]]:
    """``--run RUN…`` (required, several), with its help text."""
    return click.option(
        "--run",
        "runs",
        required=True,
        multiple=True,
        type=click.Path(path_type=Path),
        help=f"{what}: recordings (MCAP) or tables written by `thermrs extract`; FILE#RUN "
        "takes one run of a file (FILE alone: each of its runs).",
    )


TRAIN_HELP = (
    "Training runs: recordings (MCAP) or tables written by `thermrs extract` (--train A B or "
    "--train A --train B); FILE#RUN takes one run of a file (FILE alone: each of its runs)."
)


@cli.command()
@rig_option
@click.option(
    "--train",
    "train",
    required=True,
    multiple=True,
    type=click.Path(path_type=Path),
    help=TRAIN_HELP,
)
@click.option(
    "--json",
    "json_path",
    type=click.Path(path_type=Path),
    default=None,
    help="Write the SPEC §7 JSON here (atomically).",
)
def fit(rig_path: Path, train: tuple[Path, ...], json_path: Path | None) -> None:
    """Fit the expansion coefficient α over training runs: a time-series least-squares fit of
    the forward model to every visit's spot, with a 95 % interval, and the paper's start/end
    estimator per camera beside it.

    Exits 3 (after fitting) if part of a training recording was lost.
    """
    from thermrs.fit import fit_alpha, fit_alpha_start_end

    r = load_rig(rig_path)
    tables, loss = _run_tables(train, r, "--train")
    f = fit_alpha(tables, r)
    doc = f.to_json()
    start_end = {t["run"][0]: fit_alpha_start_end(t, r) for t in tables}
    doc["start_end"] = {run: se.to_json() for run, se in start_end.items()}
    if json_path is not None:
        _write_json(json_path, doc)
    t = Table(title=f"α from {len(tables)} run(s), {f.n_visits} visits")
    for col in ("estimator", "run", "camera", "α (×10⁻⁶/K)", "95 % interval", "rms (µm)"):
        t.add_column(col, justify="right" if col not in ("estimator", "run") else "left")
    t.add_row(
        "time-series",
        "all",
        "all",
        f"{f.alpha_per_k * 1e6:.3f}",
        f"{f.ci95[0] * 1e6:.3f} – {f.ci95[1] * 1e6:.3f}",
        f"{f.rms_um:.3f}",
    )
    for run, se in start_end.items():
        for cam, (a, (lo, hi)) in [*se.per_camera.items(), ("mean", se.mean)]:
            t.add_row(
                "start/end", run, cam, f"{a * 1e6:.3f}", f"{lo * 1e6:.3f} – {hi * 1e6:.3f}", ""
            )
    out.print(t)
    if loss:
        sys.exit(EXIT_DATA_LOSS)


@cli.command()
@rig_option
@runs_option("Runs to predict")
@click.option("--alpha", "alpha", type=float, default=None, help="α (1/K) to predict with.")
@click.option(
    "--fit",
    "fit_path",
    type=click.Path(path_type=Path),
    default=None,
    help="Take α from a `thermrs fit --json` file.",
)
@click.option(
    "--train",
    "train",
    multiple=True,
    type=click.Path(path_type=Path),
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
    help="Write every visit's predicted and measured drift here (Parquet, atomically).",
)
def predict(
    rig_path: Path,
    runs: tuple[Path, ...],
    alpha: float | None,
    fit_path: Path | None,
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
    from thermrs.fit import fit_alpha, fit_alpha_start_end
    from thermrs.ingest import write_parquet_atomic
    from thermrs.predict import predict as run_predict
    from thermrs.predict import prediction_table

    given = sum(x is not None and x != () for x in (alpha, fit_path, train))
    if given != 1:
        raise InputError("give exactly one of --alpha, --fit or --train")
    r = load_rig(rig_path)
    loss = False
    alphas: dict[str, float] = {}
    if alpha is not None:
        alphas["given"] = alpha
    elif fit_path is not None:
        try:
            doc = json.loads(fit_path.read_text())
            alphas["fit"] = float(doc["alpha_per_k"]["value"])
        except FileNotFoundError:
            raise InputError(f"--fit {fit_path}: no such file") from None
        except (ValueError, KeyError, TypeError) as e:
            raise InputError(
                f"--fit {fit_path}: not a `thermrs fit --json` file ({type(e).__name__}: {e})"
            ) from None
    else:
        tables, loss = _run_tables(train, r, "--train")
        alphas["series"] = fit_alpha(tables, r).alpha_per_k
        if len(tables) == 1:  # the paper's protocol: α per camera and their mean, one run
            se = fit_alpha_start_end(tables[0], r)
            for cam, (a, _) in se.per_camera.items():
                alphas[cam] = a
            alphas["mean"] = se.mean[0]
    held, lost = _run_tables(runs, r, "--run")
    loss |= lost
    table = prediction_table(held, r, alphas=alphas, axis=axis, end_visits=end_visits)
    if json_path is not None:
        _write_json(
            json_path, {"alpha_per_k": alphas, "table": table.drop("alpha_per_k").to_dicts()}
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
        write_parquet_atomic(series, series_path)
    t = Table(
        title="Predicted against measured drift at the end of each run",
        caption="α (×10⁻⁶/K): "
        + ", ".join(f"{k} {v * 1e6:.3f}" for k, v in alphas.items())
        + (" (series: time-series fit; A, B, mean: start/end)" if train else ""),
    )
    for col in ("α", "cam", "run", "axis", "pred µm", "meas µm", "err %", "rms µm", "noise µm"):
        t.add_column(col, justify="left" if col in ("α", "cam", "run", "axis") else "right")
    for row in table.iter_rows(named=True):
        t.add_row(
            row["alpha"],
            row["camera"],
            row["run"],
            row["axis"],
            f"{row['predicted_um']:.2f}",
            f"{row['measured_um']:.2f}",
            f"{row['error_pct']:+.2f}",
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


@cli.command()
@rig_option
@runs_option("Runs")
@click.option(
    "--window",
    type=click.IntRange(min=3),
    default=10,
    show_default=True,
    help="Visits per ISO 9283 window.",
)
@click.option(
    "--tolerance-um",
    type=click.FloatRange(min=0, min_open=True),
    default=1.0,
    show_default=True,
    help="Settling tolerance of the barycentre (µm).",
)
@click.option(
    "--json",
    "json_path",
    type=click.Path(path_type=Path),
    default=None,
    help="Write the curves and the ISO 9283-style figures as JSON here (atomically).",
)
def drift(
    rig_path: Path, runs: tuple[Path, ...], window: int, tolerance_um: float,
    json_path: Path | None,
) -> None:  # fmt: skip
    """How runs warm up and drift: first-order heating curves y = y₀ + A·e^(−t/τ) per ROI
    temperature and per camera drift axis, and ISO 9283-style pose figures per camera chip
    (RP cold and warm, dAP, dRP, settling time).

    Exits 3 (after reporting) if part of a recording was lost.
    """
    import polars as pl

    from thermrs.heating import heating_curves
    from thermrs.iso9283 import LABEL, iso9283

    r = load_rig(rig_path)
    tables, loss = _run_tables(runs, r, "--run")
    table = pl.concat(tables, how="diagonal_relaxed")
    curves = heating_curves(table)
    iso = iso9283(table, window=window, tolerance_um=tolerance_um)
    if json_path is not None:
        _write_json(json_path, {"curves": curves.to_dicts(), "iso9283": iso.to_json()})

    def num(x: float | None, digits: int = 2) -> str:
        return "—" if x is None else f"{x:.{digits}f}"

    t = Table(title="Heating curves y = y₀ + A·e^(−t/τ)")
    for col in ("run", "series", "y₀", "A", "τ (min)", "± τ", "rms", "phase"):
        t.add_column(col, justify="left" if col in ("run", "series", "phase") else "right")
    for row in curves.iter_rows(named=True):
        series = (
            row["series"]
            if row["kind"] == "temperature"
            else (f"drift {row['camera']} {row['axis']} (µm)")
        )
        unit = " °C" if row["kind"] == "temperature" else ""
        t.add_row(
            row["run"], series + unit, num(row["y0"]), num(row["a"]), num(row["tau_min"], 1),
            num(row["tau_min_se"], 1), num(row["rms"], 3), row["phase"] or "no fit (--json: why)",
        )  # fmt: skip
    out.print(t)
    t = Table(title=LABEL)
    for col in ("run", "cam", "RP cold µm", "RP warm µm", "dAP µm", "dRP µm", "settle min"):
        t.add_column(col, justify="left" if col in ("run", "cam") else "right")
    for row in iso.summary.iter_rows(named=True):
        t.add_row(
            row["run"], row["camera"], num(row["rp_cold_um"]), num(row["rp_warm_um"]),
            num(row["dap_um"]), num(row["drp_um"]), num(row["settle_min"], 1),
        )  # fmt: skip
    out.print(t)
    if loss:
        sys.exit(EXIT_DATA_LOSS)


#: Options that take several values (``--train A B``) as well as repeats (``--train A
#: --train B``), as SPEC §7 writes them.
MULTI_VALUE_OPTIONS = ("--train", "--holdout", "--run")


def _expand_multi(argv: list[str]) -> list[str]:
    """``--train A B --json X`` → ``--train A --train B --json X``."""
    res: list[str] = []
    opt = None
    for a in argv:
        if a == "--":
            opt = None
            res.append(a)
        elif a.startswith("-"):
            opt = a if a in MULTI_VALUE_OPTIONS else None
            res.append(a)
            if opt is not None:
                res.append("\0")  # placeholder: the first value follows the option directly
        elif opt is not None and res[-1] == "\0":
            res[-1] = a
        elif opt is not None:
            res.extend([opt, a])
        else:
            res.append(a)
    return [a for a in res if a != "\0"]


def _debug() -> bool:
    return os.environ.get("THERMRS_DEBUG", "") not in ("", "0")


def main(argv: list[str] | None = None) -> None:
    """Entry point: run the CLI and map errors to SPEC §7 exit codes."""
    try:
        args = sys.argv[1:] if argv is None else argv
        cli.main(args=_expand_multi(list(args)), prog_name="thermrs", standalone_mode=False)
    except click.exceptions.Exit as e:
        sys.exit(e.exit_code)
    except click.UsageError as e:  # one line, like every other bad input: exit 2
        cmd = e.ctx.command_path if e.ctx is not None else "thermrs"
        click.echo(f"thermrs: error: {e.format_message()} (see `{cmd} --help`)", err=True)
        sys.exit(EXIT_BAD_INPUT)
    except click.ClickException as e:  # exit 2
        e.show()
        sys.exit(EXIT_BAD_INPUT)
    except click.exceptions.Abort:
        click.echo("thermrs: interrupted", err=True)
        sys.exit(130)
    except KeyboardInterrupt:
        click.echo("thermrs: interrupted", err=True)
        sys.exit(130)
    except ThermrsError as e:
        click.echo(f"thermrs: error: {e}", err=True)
        sys.exit(EXIT_BAD_INPUT)
    except Exception as e:
        if _debug():
            traceback.print_exc()
        click.echo(
            f"thermrs: internal error: {type(e).__name__}: {e} "
            "(THERMRS_DEBUG=1 shows the traceback)",
            err=True,
        )
        sys.exit(EXIT_INTERNAL)
