"""What every command shares: the console and tables, option types, output checks and
writers, and run tables read from recordings or extracted tables (``FILE`` or ``FILE#RUN``).

Start-up is kept short (``thermrs --help``): numpy, polars, scipy and rich are imported inside
the functions that need them, never at module level; the Rust extension is loaded with
:mod:`thermrs.errors`, whose exception classes it defines.
"""

from __future__ import annotations

import os
import sys
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

import click

from thermrs.atomic import write_csv, write_json
from thermrs.defaults import VISIT_TOLERANCE_DEG
from thermrs.errors import InputError, ThermrsError

if TYPE_CHECKING:  # pragma: no cover
    import polars as pl
    from rich.console import Console
    from rich.table import Table

    from thermrs.analyses.inputs import Split
    from thermrs.compensate import DiagnosedModel
    from thermrs.rig import Rig

EXIT_OK, EXIT_INTERNAL, EXIT_BAD_INPUT, EXIT_DATA_LOSS = 0, 1, 2, 3
EXIT_INTERRUPTED = 130

#: The joint tolerance of a visit (°); the same as :data:`thermrs.visits.DEFAULT_TOLERANCE_DEG`
#: (a test checks), from :mod:`thermrs.defaults` so that ``thermrs --help`` need not import polars.
__all__ = [
    "CAMPAIGN_NAMES_HELP",
    "TRAIN_HELP",
    "VISIT_TOLERANCE_DEG",
    "AlphaType",
    "campaign_options",
    "chosen_runs",
    "chosen_splits",
    "console",
    "exclude_option",
    "file_tables",
    "input_file",
    "json_option",
    "no_campaign",
    "out",
    "out_option",
    "rig_option",
    "rule_option",
    "run_file",
    "runs_option",
    "seed_option",
    "table",
    "where_option",
    "writable",
    "write_csv",
    "write_json",
]


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


class Stage(Protocol):
    """Progress told to :func:`stages`: the stage, with ``done`` of ``total`` bytes
    (or steps) when known."""

    def __call__(self, stage: str, done: int = 0, total: int = 0) -> None: ...


@contextmanager
def stages(command: str, *, verbose: bool = False, quiet: bool = False) -> Iterator[Stage]:
    """Progress of a command that takes a while, on stderr: the one progress of the CLI;
    yields ``say(stage, done=0, total=0)``.

    On a terminal, a spinner with the stage (a bar when ``total`` is given); piped, one line
    per new stage with the seconds since the command began (``thermrs diagnose: step 2 …
    (4.1 s)``), so that a log shows where the time goes. ``quiet``: neither. With
    ``verbose``, the seconds each stage took, at the end.
    """
    t0 = time.perf_counter()
    spent: dict[str, float] = {}
    cur: list[Any] = [None, t0]

    def mark(stage: str | None) -> bool:
        now = time.perf_counter()
        new = bool(stage != cur[0])
        if new:
            if cur[0] is not None:
                spent[cur[0]] = spent.get(cur[0], 0.0) + now - cur[1]
            cur[0], cur[1] = stage, now
        return new

    if quiet:

        def say(stage: str, done: int = 0, total: int = 0) -> None:
            mark(stage)

        yield say
    elif sys.stderr.isatty():
        from rich.progress import BarColumn, Progress, SpinnerColumn, TextColumn, TimeElapsedColumn

        with Progress(
            SpinnerColumn(),
            TextColumn(f"[bold]{command}[/bold] {{task.description}}"),
            BarColumn(),
            TextColumn("{task.fields[info]}"),
            TimeElapsedColumn(),
            console=console(stderr=True),
            transient=True,
        ) as bar:
            task = bar.add_task("…", total=None, info="")

            def say(stage: str, done: int = 0, total: int = 0) -> None:
                mark(stage)
                info = f"{done / 1e6:,.0f}/{total / 1e6:,.0f} MB" if total else ""
                bar.update(
                    task, description=f"{stage}…", completed=done, total=total or None, info=info
                )

            yield say
    else:

        def say(stage: str, done: int = 0, total: int = 0) -> None:
            if mark(stage):
                click.echo(
                    f"thermrs {command}: {stage} ({time.perf_counter() - t0:.1f} s)", err=True
                )

        yield say
    mark(None)
    if verbose:
        for stage, sec in spent.items():
            click.echo(f"thermrs {command}: {sec:7.2f} s  {stage}", err=True)
        click.echo(f"thermrs {command}: {time.perf_counter() - t0:7.2f} s  in all", err=True)


def verbose_option(f: Callable[..., Any]) -> Callable[..., Any]:
    """``--verbose``: the seconds each stage took, on stderr at the end."""
    return click.option(
        "--verbose", is_flag=True, help="Print the seconds each stage took (stderr)."
    )(f)


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
    the file must exist and not be a folder, unless the folder is a bag (one recording)."""

    name = "RUN"

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> Any:
        text = str(value)
        if ctx is not None and ctx.params.get("campaign_path") is not None:
            return text  # a run of the --campaign dataset, named recording#run
        path = Path(text)
        if "#" in text and not path.exists():
            path = Path(text.rpartition("#")[0])
        if path.is_dir():
            from thermrs.ingest import NOT_A_BAG, is_bag

            if not is_bag(path):
                self.fail(f"{path}: {NOT_A_BAG}", param, ctx)
        if not path.exists():
            self.fail(f"{str(path)!r} does not exist.", param, ctx)
        return Path(text)


#: ``FILE`` or ``FILE#RUN`` of a recording or extracted tables.
run_file = RunFileType()

#: ``--rig RIG``, shared by the commands that read recordings.
rig_option = click.option(
    "--rig", "rig_path", required=True, type=input_file, help="Rig file (TOML, SPEC §3)."
)


def out_option(
    what: str, *, required: bool = True
) -> Callable[[Callable[..., Any]], Callable[..., Any]]:
    """``-o/--out PATH`` with its help text (optional with ``required=False``: None)."""
    return click.option(
        "-o",
        "--out",
        "out_path",
        required=required,
        default=None,
        type=click.Path(path_type=Path),
        help=what,
    )


def writable(path: Path | None, option: str, *, suffixes: Sequence[str] = ()) -> None:
    """Check before any work that an output can be written (its folder exists and takes a
    new file; it is not a folder) and, with ``suffixes``, that its name says its format.

    Raises
    ------
    InputError
        One line naming the option, the path and what is wrong (bad input: exit 2).
    OutputError
        The folder exists but takes no new file (no permission, a read-only or full disk):
        a write failure, exit 1.
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


#: Files read by this process's command, by path: `predict --train rec#run1 --run rec#run2`
#: extracts `rec` once (passed to :func:`thermrs.analyses.inputs.file_tables`).
_FILES: dict[Any, Any] = {}


def say(line: str) -> None:
    """A line for the user on stderr, ``thermrs: `` first."""
    click.echo(f"thermrs: {line}", err=True)


def file_tables(paths: Sequence[Any], rig: Rig, what: str) -> tuple[list[pl.DataFrame], bool]:
    """:func:`thermrs.analyses.inputs.file_tables`, the runs found told on stderr and files
    read once per command."""
    from thermrs.analyses import inputs

    return inputs.file_tables(paths, rig, what, say=say, cache=_FILES)


Decorator = Callable[[Callable[..., Any]], Callable[..., Any]]

#: How a run is named in a campaign dataset (the help of every run option).
CAMPAIGN_NAMES_HELP = (
    " With --campaign: runs of the dataset, RECORDING#RUN (RECORDING the catalog's id or "
    "the file's stem; alone: each of its runs)."
)


def runs_option(what: str, *, name: str = "--run", dest: str = "runs") -> Decorator:
    """``--run RUN…`` (several; required unless ``--campaign`` chooses runs), with its help."""
    return click.option(
        name,
        dest,
        multiple=True,
        type=run_file,
        help=f"{what}: recordings (MCAP) or tables written by `thermrs extract`; FILE#RUN "
        "takes one run of a file (FILE alone: each of its runs)." + CAMPAIGN_NAMES_HELP,
    )


TRAIN_HELP = (
    "Training runs: recordings (MCAP) or tables written by `thermrs extract` (--train A B or "
    "--train A --train B); FILE#RUN takes one run of a file (FILE alone: each of its runs)."
)


def json_option(what: str = "Write the SPEC §7 JSON here (atomically).") -> Decorator:
    """``--json PATH``, with its help text."""
    return click.option(
        "--json", "json_path", type=click.Path(path_type=Path), default=None, help=what
    )


def seed_option(what: str) -> Decorator:
    """``--seed N`` (default 0)."""
    return click.option(
        "--seed",
        default=0,
        show_default=True,
        type=click.IntRange(0, 2**32 - 1),
        help=what,
    )


def exclude_option(what: str) -> Decorator:
    """``--exclude EFFECT…``: SPEC §6 effects the diagnoser may not name."""
    return click.option("--exclude", "exclude", multiple=True, help=what)


#: ``--where QUERY``: the runs of a campaign dataset to use.
where_option = click.option(
    "--where",
    "query",
    default=None,
    metavar="QUERY",
    help="Runs to use: KEY OP VALUE terms, comma-separated (keys robot, rig (title or rig "
    "file), recording (id or stem), run, date (2026-11-02, 02.11.2026, …), speed% (override), "
    "speed (°/s), duration (s)), e.g. 'date>=2026-11-02, speed%>=50'; quote a value with a "
    "comma. "
    "`thermrs campaign DATASET --list` lists the values there are.",
)


def rule_option(what: str) -> Decorator:
    """``--rule leave-one-run-out|by-day``: training and held-out runs by rule."""
    return click.option(
        "--rule", type=click.Choice(["leave-one-run-out", "by-day"]), default=None, help=what
    )


def campaign_options(*, rule: str | None = None) -> Decorator:
    """``--campaign DATASET`` and ``--where QUERY`` (and, with ``rule`` its help, ``--rule``):
    runs read from a campaign dataset (``thermrs extract REC… -o DATASET``) instead of files.
    ``--campaign`` is processed first, so that run options then take ``RECORDING#RUN``."""

    def deco(f: Callable[..., Any]) -> Callable[..., Any]:
        if rule is not None:
            f = rule_option(rule)(f)
        f = where_option(f)
        return click.option(
            "--campaign",
            "campaign_path",
            type=click.Path(path_type=Path),
            default=None,
            is_eager=True,
            metavar="DATASET",
            help="Read the runs from this campaign dataset (written by `thermrs extract "
            "REC… -o DATASET`): every run, or those --where and the run options choose.",
        )(f)

    return deco


def fold_options(f: Callable[..., Any]) -> Callable[..., Any]:
    """``--workers N`` and ``--scheduler ADDRESS``: where a --rule's folds run side by side
    (:func:`thermrs.analyses.folds.map_folds`)."""
    f = click.option(
        "--workers",
        type=click.IntRange(min=1),
        default=None,
        help="With --rule: worker processes of the local Dask cluster the folds run on side "
        "by side (default: the cores, when the folds are worth a cluster's start; 1: one "
        "after another in this process).",
    )(f)
    return click.option(
        "--scheduler",
        metavar="ADDRESS",
        default=None,
        help="With --rule: a Dask scheduler to run the folds on (tcp://host:8786).",
    )(f)


def no_campaign(campaign_path: Path | None, query: str | None, rule: str | None = None) -> None:
    """``--where`` and ``--rule`` only with ``--campaign``.

    Raises
    ------
    click.UsageError
        One line saying so.
    """
    if campaign_path is None and (query is not None or rule is not None):
        opt = "--where" if query is not None else "--rule"
        raise click.UsageError(f"{opt} chooses runs of a campaign: give --campaign DATASET")


def chosen_runs(
    campaign_path: Path | None,
    query: str | None,
    names: Sequence[Any],
    rig: Rig,
    what: str,
) -> tuple[list[pl.DataFrame], bool]:
    """Run tables and whether data was lost: from the ``--campaign`` dataset (the runs
    ``--where`` selects, or those named among them) or from files (``names`` required)."""
    no_campaign(campaign_path, query)
    if campaign_path is None:
        if not names:
            raise click.UsageError(f"Missing option '{what}' (or --campaign DATASET).")
        return file_tables(tuple(names), rig, what)
    from thermrs.analyses.inputs import selected

    s = selected(campaign_path, rig, where=query, names=[str(n) for n in names], what=what)
    _say_split(campaign_path, what, s.train_names, s.data_loss)
    return s.train, s.data_loss


def _say_split(campaign_path: Path, what: str, names: Sequence[str], loss: bool) -> None:
    if names:
        say(
            f"{what} {campaign_path}: {len(names)} run{'s' * (len(names) != 1)}: "
            + ", ".join(names)
        )
    if loss:
        say(
            f"data loss: {campaign_path}: a recording of these runs lost part of its data (see "
            "the catalog's loss_detail); results use what was intact"
        )


def chosen_splits(
    campaign_path: Path | None,
    query: str | None,
    rule: str | None,
    train: Sequence[Any],
    holdout: Sequence[Any],
    rig: Rig,
    *,
    holdout_what: str = "--holdout",
) -> list[Split]:
    """Training and held-out run tables: a split per fold of ``--rule`` or the runs named,
    from the ``--campaign`` dataset; from files, the one split of ``--train``/``--holdout``
    (both lists of files) (:mod:`thermrs.analyses.inputs`). A held-out run may not be a
    training run again."""
    from thermrs.analyses.inputs import check_splits, file_splits, splits

    no_campaign(campaign_path, query, rule)
    if campaign_path is None:
        for opt, given in (("--train", train), (holdout_what, holdout)):
            if not given:
                raise click.UsageError(f"Missing option '{opt}' (or --campaign DATASET).")
        return file_splits(
            tuple(train), tuple(holdout), rig, holdout_what=holdout_what, say=say, cache=_FILES
        )
    sets = splits(
        campaign_path,
        rig,
        where=query,
        rule=rule,
        train=[str(n) for n in train],
        holdout=[str(n) for n in holdout],
    )
    for s in sets:
        say(
            f"{campaign_path}: {s.name or 'runs'}: train on {', '.join(s.train_names)}; hold "
            f"out {', '.join(s.holdout_names) or 'none'}"
        )
    if any(s.data_loss for s in sets):
        _say_split(campaign_path, "runs", [], True)
    check_splits(sets, holdout_what=holdout_what)
    return sets


def say_model(m: DiagnosedModel) -> None:
    """The diagnosed model a command uses, told on stderr (with its note, if any)."""
    from thermrs.diagnose.verdict import format_params

    effects = ", ".join(
        e.name + " " + format_params({k: v for k, v in e.to_dict().items() if k != "name"})
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
