"""The ``thermrs`` command line: a thin layer over the library API.

Exit codes (SPEC §7): 0 success; 2 bad input or usage (one line on stderr, no traceback);
3 finished with data loss; 1 internal error (set ``THERMRS_DEBUG=1`` for the traceback);
130 interrupted (Ctrl-C).

Start-up is kept short (``thermrs --help``): numpy, polars, scipy, rich and the Rust
extension are imported inside the commands that need them, never at module level.

Commands live on the :func:`cli` group; another module adds one with
``cli.add_command(my_command)`` (a ``click.Command``), using the shared options below
(:data:`rig_option`, :func:`out_option`, :func:`runs_option`, :data:`input_file`) and
:func:`console` / :func:`table` for output.
"""

from __future__ import annotations

import os
import signal
import sys


def _interrupted_early(signum: int, frame: object) -> None:
    """Ctrl-C while the CLI starts (imports): stop at once with the one line of SPEC §7.
    Nothing has been written yet; :func:`main` hands Ctrl-C back to Python before any work."""
    sys.stderr.write("thermrs: interrupted\n")
    sys.stderr.flush()
    os._exit(130)


# Installed before anything heavy is imported, unless Ctrl-C is ignored (a background job).
def _invoked_as_cli() -> bool:
    """Whether this process is the ``thermrs`` command (the console script or ``python -m
    thermrs``), not a program that imports the module (a test runner, a notebook)."""
    argv0 = os.path.basename(sys.argv[0]) if sys.argv and sys.argv[0] else ""
    return argv0 in ("thermrs", "__main__.py") and (
        argv0 == "thermrs" or os.path.basename(os.path.dirname(sys.argv[0])) == "thermrs"
    )


_EARLY = signal.getsignal(signal.SIGINT) is signal.default_int_handler and _invoked_as_cli()
if _EARLY:
    signal.signal(signal.SIGINT, _interrupted_early)

import json  # noqa: E402
import time  # noqa: E402
import traceback  # noqa: E402
from collections.abc import Callable, Sequence  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import TYPE_CHECKING, Any  # noqa: E402

import click  # noqa: E402

from thermrs.errors import InputError, ThermrsError  # noqa: E402

if TYPE_CHECKING:  # pragma: no cover
    import polars as pl
    from rich.console import Console
    from rich.table import Table

    from thermrs.rig import Rig

EXIT_OK, EXIT_INTERNAL, EXIT_BAD_INPUT, EXIT_DATA_LOSS = 0, 1, 2, 3
EXIT_INTERRUPTED = 130

#: The joint tolerance of a visit (°); the same as :data:`thermrs.visits.DEFAULT_TOLERANCE_DEG`
#: (a test checks), from :mod:`thermrs.defaults` so that ``thermrs --help`` need not import polars.
from thermrs.defaults import ISO_TOLERANCE_UM, ISO_WINDOW, VISIT_TOLERANCE_DEG  # noqa: E402


def console(*, stderr: bool = False) -> Console:
    """A rich console on stdout (or stderr). On a terminal it takes the terminal's width (or
    ``COLUMNS``); piped into a file or another program it never cuts or wraps a table."""
    from rich.console import Console

    stream = sys.stderr if stderr else sys.stdout
    width = None
    if not os.environ.get("COLUMNS", "").isdigit() and not stream.isatty():
        width = 100_000
    return Console(stderr=stderr, highlight=False, width=width, soft_wrap=width is not None)


class _LazyConsole:
    """The stdout console, made on first use (rich is not imported for ``--help``)."""

    _console: Console | None = None

    def __getattr__(self, name: str) -> Any:
        if self._console is None:
            self._console = console()
        return getattr(self._console, name)


out: Any = _LazyConsole()


def table(title: str, columns: Sequence[tuple[str, str]], *, caption: str | None = None) -> Table:
    """A table whose cells fold rather than being cut at a narrow terminal: headers keep
    their words whole (each column at least as wide as its header's longest word) and long
    cells (run names, paths) wrap onto a second line instead of ending in "…".

    ``columns`` are ``(header, justify)`` pairs, ``justify`` one of ``left``, ``right``.
    """
    from rich.table import Table

    t = Table(title=title, caption=caption, title_justify="left", caption_justify="left")
    for name, justify in columns:
        longest = max((len(w) for w in name.split()), default=0)
        t.add_column(name, justify=justify, overflow="fold", min_width=longest)  # type: ignore[arg-type]
    return t


#: An input file that must exist and be a file (not a folder): a usage error otherwise.
input_file = click.Path(exists=True, dir_okay=False, readable=True, path_type=Path)


class RunFileType(click.ParamType):  # type: ignore[type-arg]
    """A run: a recording or extracted tables, optionally ``FILE#RUN`` (one run of the file);
    the file must exist and not be a folder."""

    name = "RUN"

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        text = str(value)
        path = Path(text)
        if "#" in text and not path.exists():
            path = Path(text.rpartition("#")[0])
        if path.is_dir():
            self.fail(f"{path}: is a directory, expected a recording (.mcap) or tables", param, ctx)
        if not path.exists():
            self.fail(f"{str(path)!r} does not exist.", param, ctx)
        return Path(text)


#: ``FILE`` or ``FILE#RUN`` of a recording or extracted tables.
run_file = RunFileType()

#: ``--rig RIG``, shared by the commands that read recordings.
rig_option = click.option(
    "--rig", "rig_path", required=True, type=input_file, help="Rig file (TOML, SPEC §3)."
)


def out_option(what: str) -> Callable[[Callable[..., Any]], Callable[..., Any]]:
    """``-o/--out PATH`` with its help text."""
    return click.option(
        "-o", "--out", "out_path", required=True, type=click.Path(path_type=Path), help=what
    )


def writable(path: Path | None, option: str, *, suffixes: Sequence[str] = ()) -> None:
    """Check before any work that an output can be written (its folder exists and takes a
    new file; it is not a folder) and, with ``suffixes``, that its name says its format.

    Raises
    ------
    InputError
        One line naming the option, the path and what is wrong.
    """
    if path is None:
        return
    from thermrs.ingest import check_writable

    if path.is_dir():
        raise InputError(f"{option} {path}: is a directory, expected a file name")
    if suffixes and not any(path.name.endswith(s) for s in suffixes):
        raise InputError(
            f"{option} {path}: the name must end in {' or '.join(suffixes)} (the format written)"
        )
    check_writable(path, what=option)


class AlphaType(click.ParamType):  # type: ignore[type-arg]
    """An expansion coefficient (1/K): a number (``2.32e-05``, ``23.2e-6``) or one with an SI
    prefix for ×10⁻⁶ (``23.2u``, ``23.2µ``, ``23.2ppm``); positive and below 10⁻³ /K."""

    name = "ALPHA"

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        if isinstance(value, float):
            return value
        text = str(value).strip().removesuffix("/K").removesuffix("/k").strip()
        scale = 1.0
        for suffix in ("ppm", "µ", "μ", "u"):
            if text.endswith(suffix):
                text, scale = text[: -len(suffix)].strip(), 1e-6
                break
        try:
            a = float(text) * scale
        except ValueError:
            self.fail(
                f"{value!r} is not a number; write α per kelvin as 23.2e-6 or 23.2u", param, ctx
            )
        from thermrs.predict import check_alpha

        try:
            return check_alpha(a, what="α", positive=True)
        except ThermrsError as e:
            msg = str(e)
            if "write" in msg:
                msg += f" or {a:g}u"
            self.fail(msg, param, ctx)


def _fmt(x: float | None, digits: int = 2) -> str:
    from thermrs.numbers import fmt

    return fmt(x, digits)


class _Interrupted(Exception):
    """Ctrl-C, carried past click (which would print an empty line first)."""


class ThermrsGroup(click.Group):
    """The command group; every command, including those other modules add with
    ``cli.add_command``, runs through :meth:`invoke`."""

    def invoke(self, ctx: click.Context) -> Any:
        try:
            return super().invoke(ctx)
        except KeyboardInterrupt:
            raise _Interrupted() from None


@click.group(cls=ThermrsGroup, context_settings={"help_option_names": ["-h", "--help"]})
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
    from thermrs import paper as paper_mod

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
    t6 = table(
        f"Table 6 — α from Run {train_run} (×10⁻⁶ /°C)",
        [(c, "right" if c != "α" else "left") for c in ("α", "thermrs", "paper", "Δ")],
    )
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
    t7 = table(
        "Table 7 — predicted vs measured Δl_x (µm), error (%)",
        [
            (c, "left" if c in ("α", "camera") else "right")
            for c in (
                "α",
                "camera",
                "run",
                "predicted",
                "measured",
                "error %",
                "paper pred.",
                "paper meas.",
                "paper err.",
            )
        ],
    )
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
    tf = table(
        "Generalised — the same protocol through the SPEC §4 forward model "
        "(embedded rig; drift along the chip y axis)",
        [
            (c, "left" if c in ("α", "camera") else "right")
            for c in ("α", "α (×10⁻⁶/°C)", "camera", "run", "predicted", "measured", "error %")
        ],
    )
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
@click.argument("rig_path", required=False, type=input_file)
@click.option("--json", "as_json", is_flag=True, help="Print SPEC §7 JSON instead of tables.")
def rig(rig_path: Path | None, as_json: bool) -> None:
    """Check and explain a rig file (default: the embedded paper rig).

    Per pose: the flange position and, for every camera, where the laser meets its chip and
    at what incidence. Exits 2 if the laser misses a pose's own camera.
    """
    from thermrs.rig import default_rig_path, load_rig

    r = load_rig(rig_path)
    try:
        view = r.check()
    except ThermrsError as e:
        raise InputError(f"{e}{_radians_hint(r)}") from None
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
        t = table(
            f"Pose {pose_name}: flange ({x:.2f}, {y:.2f}, {z:.2f}) mm, "
            f"elevation {p['elevation_deg']:.2f}°, azimuth {p['azimuth_deg']:.2f}°",
            [
                (c, "left" if c in ("camera", "") else "right")
                for c in (
                    "camera",
                    "spot x (px)",
                    "spot y (px)",
                    "incidence (°)",
                    "distance (mm)",
                    "",
                )
            ],
        )
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
@click.argument("recording", type=input_file)
@rig_option
@out_option(
    "Frames Parquet (OUT.parquet, in an existing folder); visits, temperatures and joints "
    "are written beside it."
)
@click.option(
    "--visit-tolerance-deg",
    type=click.FloatRange(min=0, min_open=True, max=180),
    default=VISIT_TOLERANCE_DEG,
    show_default=True,
    help="Joint tolerance (°) for a spot frame to count as at its camera's pose.",
)
@click.option(
    "--quiet", is_flag=True, help="No progress bar or summary (a data loss is still reported)."
)
def extract(
    recording: Path, rig_path: Path, out_path: Path, visit_tolerance_deg: float, quiet: bool
) -> None:
    """Extract a recording into Parquet tables: frames (spot centroids), visits,
    temperatures (thermal ROI maxima and ambient) and joints.

    Exits 3 (after writing every table) if part of the recording was lost: a file cut short,
    a corrupt chunk. The tables remember it (Parquet metadata): fit, predict and drift on
    them exit 3 too.
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
    from thermrs.rig import load_rig

    writable(out_path, "-o", suffixes=(".parquet",))
    r = load_rig(rig_path)
    err = console(stderr=True)
    with Progress(
        TextColumn("[bold]extract[/bold]"),
        BarColumn(),
        DownloadColumn(),
        TextColumn("{task.fields[fps]}"),
        TimeElapsedColumn(),
        TimeRemainingColumn(),
        console=err,
        disable=quiet or not err.is_terminal,  # a bar only where it can redraw
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
        t = table("Frames by status", [("status", "left"), ("frames", "right")])
        for k, v in rep.frames_by_status.items():
            t.add_row(k, f"{v:,}")
        err.print(t)
        if rep.skipped:
            s = table(
                "Skipped messages", [("topic: reason (first seen)", "left"), ("count", "right")]
            )
            for k, v in rep.skipped.items():
                s.add_row(rep.skipped_examples.get(k, k), f"{v:,}")
            err.print(s)
        if rep.recovered_messages:
            err.print(f"recovered {rep.recovered_messages} complete messages from the cut chunk")
        for name, p in paths.items():
            err.print(f"wrote {name}: {p}")
    # The loss is reported even with --quiet: exit 3 never goes unexplained.
    for loss in rep.losses:
        click.echo(f"thermrs: data loss: {recording}: {loss['detail']}", err=True)
    if rep.data_loss:
        sys.exit(EXIT_DATA_LOSS)


@cli.command()
@rig_option
@click.option(
    "--scenario",
    "scenario_path",
    required=True,
    type=input_file,
    help="Scenario file (thermrs-scenario/1; see docs/scenarios.md).",
)
@out_option("Recording to write (OUT.mcap, in an existing folder); the truth is written beside it.")
@click.option(
    "--seed",
    type=click.IntRange(min=0, max=2**64 - 1),
    default=None,
    help="Override the scenario's seed (0 ≤ N < 2⁶⁴).",
)
def simulate(rig_path: Path, scenario_path: Path, out_path: Path, seed: int | None) -> None:
    """Simulate a rig at work: write a recording in the rig's own format and its truth
    (OUT.truth.parquet, OUT.truth-samples.parquet, OUT.truth.json)."""
    from thermrs.rig import load_rig
    from thermrs.simulate import simulate as run_simulate

    writable(out_path, "-o", suffixes=(".mcap",))
    r = load_rig(rig_path)
    t0 = time.perf_counter()
    sim = run_simulate(r, scenario_path, out_path, seed=seed)
    dt = time.perf_counter() - t0
    err = console(stderr=True)
    size = sim.recording.stat().st_size / 1e6
    err.print(
        f"wrote {sim.recording} ({size:,.1f} MB): {sim.frames.height:,} CCD frames, "
        f"{sim.samples.height:,} thermal samples in {dt:.1f} s"
    )


def _write_json(path: Path, doc: object) -> None:
    """Write ``doc`` as JSON to ``path`` atomically."""
    from thermrs.atomic import write_json

    write_json(path, doc)


#: Files read by this process's command, by path: `predict --train rec#run1 --run rec#run2`
#: extracts `rec` once.
_FILES: dict[Any, Any] = {}


def _run_tables(paths: tuple[Path, ...], rig: Rig, what: str) -> tuple[list[pl.DataFrame], bool]:
    """Run tables of recordings or extracted tables (``FILE`` or ``FILE#RUN``), and whether
    any recording lost data (for extracted tables: as their Parquet metadata records); lists
    the runs found in each file on stderr."""
    from thermrs.fit import run_name
    from thermrs.runs import load_runs, split_run_spec

    seen: set[str] = set()
    for p in paths:
        key = f"{split_run_spec(p)[0].resolve()}#{split_run_spec(p)[1]}"
        if key in seen:
            raise InputError(f"{what} {p}: given twice")
        seen.add(key)
    tables, loss = [], False
    names = [run_name(split_run_spec(p)[0]) for p in paths]
    for p, name in zip(paths, names, strict=True):
        # Two runs of one name (r30.mcap and r30.parquet, or one name in two folders): name
        # the runs by the paths given, so that no two share a key.
        base = split_run_spec(p)[0]
        same = sum(
            1
            for q, n in zip(paths, names, strict=True)
            if n == name and split_run_spec(q)[0] != base
        )
        rt = load_runs(p, rig, name=str(base) if same else None, cache=_FILES)
        click.echo(f"thermrs: {what} {rt.describe()}", err=True)
        for t in rt.tables:
            if t.height == 0:
                raise InputError(f"{what} {p}: no visit with a spot" + _radians_hint(rig))
        if rt.data_loss:
            click.echo(
                f"thermrs: data loss: {p}: part of the recording was lost "
                "(see `thermrs extract` for what); results use what was intact",
                err=True,
            )
        tables.extend(rt.tables)
        loss |= rt.data_loss
    return tables, loss


def _radians_hint(rig: Rig) -> str:
    """Why no visit may have matched: poses given in radians where degrees are expected."""
    import math

    small = [p.name for p in rig.poses.values() if all(abs(q) <= 2 * math.pi for q in p.joints_deg)]
    if small and len(small) == len(rig.poses):
        return (
            f" (rig {Path(rig.source).name}: every pose's joints_deg lies within ±2π, like "
            "radians; poses are in degrees, as the controller reports them)"
        )
    return ""


def distinct_runs(
    train: Sequence[pl.DataFrame], held: Sequence[pl.DataFrame], what: str = "--holdout"
) -> None:
    """A held-out run must not be a training run again (a copy of its recording, say).

    Raises
    ------
    InputError
        One line naming both runs.
    """
    from thermrs.runs import same_runs

    for a, b in same_runs(train, held):
        raise InputError(
            f"{what} run {b} is identical to training run {a} (same visits, times and spots): "
            "a held-out run must be another run"
        )


def runs_option(what: str) -> Callable[[Callable[..., Any]], Callable[..., Any]]:
    """``--run RUN…`` (required, several), with its help text."""
    return click.option(
        "--run",
        "runs",
        required=True,
        multiple=True,
        type=run_file,
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
    type=run_file,
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
    from thermrs.rig import load_rig
    from thermrs.workflows import fit_document

    writable(json_path, "--json")
    r = load_rig(rig_path)
    tables, loss = _run_tables(train, r, "--train")
    result = fit_document(tables, r)
    f, start_end, doc = result.fit, result.start_end, result.to_json()
    if json_path is not None:
        _write_json(json_path, doc)
    t = table(
        f"α from {len(tables)} run(s), {f.n_visits} visits",
        [
            (c, "right" if c not in ("estimator", "run") else "left")
            for c in ("estimator", "run", "camera", "α (×10⁻⁶/K)", "95 % interval", "rms (µm)")
        ],
    )
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
        from thermrs.cli_compensate import predict_diagnosed

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
        tables, loss = _run_tables(train, r, "--train")
        alphas.update(training_alphas(fit_document(tables, r)))
    held, lost = _run_tables(runs, r, "--run")
    loss |= lost
    if train:
        distinct_runs(tables, held, "--run")
    result = prediction_table(held, r, alphas=alphas, axis=axis, end_visits=end_visits)
    if json_path is not None:
        _write_json(
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
            _write_csv(series_path, series)
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


@cli.command()
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
    from thermrs.rig import load_rig

    writable(json_path, "--json")
    r = load_rig(rig_path)
    tables, loss = _run_tables(runs, r, "--run")
    joined = pl.concat(tables, how="diagonal_relaxed")
    curves = heating_curves(joined)
    iso = iso9283(joined, window=window, tolerance_um=tolerance_um)
    if json_path is not None:
        _write_json(json_path, {"curves": curves.to_dicts(), "iso9283": iso.to_json()})

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


def _write_csv(path: Path, df: pl.DataFrame) -> None:
    """Write ``df`` as CSV to ``path`` atomically."""
    from thermrs.atomic import write_csv

    write_csv(path, df)


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


def _is_interrupt(e: BaseException) -> bool:
    """Whether ``e`` is Ctrl-C or came from it (a library that turns a KeyboardInterrupt
    during its import into an ImportError, say)."""
    seen: set[int] = set()
    x: BaseException | None = e
    while x is not None and id(x) not in seen:
        if isinstance(x, (KeyboardInterrupt, _Interrupted)):
            return True
        seen.add(id(x))
        x = x.__cause__ or x.__context__
    return False


def _exit_interrupted() -> None:
    """One line, exit 130, at once: the stack has unwound (temporary files are gone); nothing
    in the interpreter's shutdown may turn this into another exit status."""
    click.echo("thermrs: interrupted", err=True)
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(EXIT_INTERRUPTED)


def main(argv: list[str] | None = None) -> None:
    """Entry point: run the CLI and map errors to SPEC §7 exit codes.

    Anything unexpected (a Python exception, or a Rust panic: pyo3's ``PanicException`` is a
    ``BaseException``) exits 1 with one line; ``THERMRS_DEBUG=1`` adds the traceback.
    """
    from thermrs.errors import InternalError

    if _EARLY and signal.getsignal(signal.SIGINT) is _interrupted_early:
        # From here Ctrl-C raises KeyboardInterrupt, so that whatever is being written is
        # removed on the way out (and the Rust loops see it between chunks).
        signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        args = sys.argv[1:] if argv is None else argv
        cli.main(args=_expand_multi(list(args)), prog_name="thermrs", standalone_mode=False)
        if _invoked_as_cli():
            # Done and reported: a Ctrl-C while the interpreter shuts down must not turn exit 0
            # into death by SIGINT (Python re-raises an uncaught KeyboardInterrupt as a signal).
            signal.signal(signal.SIGINT, signal.SIG_IGN)
    except click.exceptions.Exit as e:
        sys.exit(e.exit_code)
    except click.UsageError as e:  # one line, like every other bad input: exit 2
        cmd = e.ctx.command_path if e.ctx is not None else "thermrs"
        click.echo(f"thermrs: error: {e.format_message()} (see `{cmd} --help`)", err=True)
        sys.exit(EXIT_BAD_INPUT)
    except click.ClickException as e:  # exit 2
        e.show()
        sys.exit(EXIT_BAD_INPUT)
    except (click.exceptions.Abort, KeyboardInterrupt, _Interrupted):
        _exit_interrupted()
    except InternalError as e:  # a panic in the core, caught by the bindings: exit 1
        if _debug():
            traceback.print_exc()
        click.echo(f"thermrs: {e}", err=True)
        sys.exit(EXIT_INTERNAL)
    except ThermrsError as e:
        click.echo(f"thermrs: error: {e}", err=True)
        sys.exit(EXIT_BAD_INPUT)
    except (SystemExit, GeneratorExit):
        raise
    except BaseException as e:
        if _is_interrupt(e):
            _exit_interrupted()
        if _debug():
            traceback.print_exc()
        first = str(e).strip().splitlines()
        click.echo(
            f"thermrs: internal error: {type(e).__name__}: {first[0] if first else ''} "
            "(THERMRS_DEBUG=1 shows the traceback)",
            err=True,
        )
        sys.exit(EXIT_INTERNAL)


def _register() -> None:
    """Commands that live in their own modules."""
    from thermrs import cli_report  # noqa: F401  (its @cli.command registers `thermrs report`)
    from thermrs.cli_compensate import compensate
    from thermrs.cli_diagnose import diagnose, diagnose_bench
    from thermrs.cli_info import info

    cli.add_command(info)
    cli.add_command(compensate)
    cli.add_command(diagnose)
    cli.add_command(diagnose_bench)


_register()
