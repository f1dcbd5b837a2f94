"""The inputs of fit, predict, drift, diagnose, design and the report: run tables from files
(:func:`file_tables`, :func:`file_splits`) or from a campaign dataset, runs chosen by query
(:func:`thermrs.campaigns.select.parse_query`) and by name, training and held-out sets by rule
(:func:`thermrs.campaigns.select.folds`) or by name.

A file is a recording (``.mcap``) or the tables ``thermrs extract`` wrote, ``FILE#RUN`` one
of its runs (:func:`thermrs.runs.load_runs`); a file given twice, a file without a visit, a
held-out run identical to a training run are refused in one line.

A run's name in a campaign is ``<recording>#<run>``, ``<recording>`` the catalog's id
(``r30-1a2b3c4d5e6f``: the file's stem and its content hash) or, where only one recording of
the campaign has it, the file's stem alone (``r30#run2``); ``<recording>`` without ``#RUN``
names each of its runs.

Training and held-out sets (:func:`splits`): by ``rule``, one :class:`Split` per fold; else
one split of the runs named: ``train`` and ``holdout`` both given, as given; only ``train``,
the other selected runs are held out; only ``holdout``, the other selected runs train;
neither, every selected run trains and none is held out.
"""

from __future__ import annotations

import os
import re
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import polars as pl

from thermrs.campaigns.dataset import Dataset
from thermrs.campaigns.select import campaign_runs, folds, run_tables
from thermrs.errors import InputError
from thermrs.rig import radians_hint

__all__ = [
    "FileRead",
    "Split",
    "check_splits",
    "distinct_runs",
    "file_splits",
    "file_tables",
    "open_dataset",
    "pick_runs",
    "read_files",
    "select_runs",
    "selected",
    "splits",
]

#: Called with a line for the user (the CLI prints it on stderr).
Say = Callable[[str], object]

_ID_HASH = re.compile(r"-[0-9a-f]{12}$")

DatasetLike = Dataset | str | os.PathLike[str]


@dataclass(frozen=True)
class Split:
    """One training / held-out set of run tables (a fold of a rule, or the runs named).

    Attributes
    ----------
    name
        The fold's name (``without r1#run2``, ``train 2026-11-02, hold out 2026-11-03``), or
        ``""`` for the runs named.
    train, holdout
        Run tables (:func:`thermrs.fit.run_table_from`), ``run`` column ``<recording>#<run>``.
    data_loss
        Whether a recording they come from lost data (the catalog's ``losses``).
    """

    name: str
    train: list[pl.DataFrame]
    holdout: list[pl.DataFrame] = field(default_factory=list)
    data_loss: bool = False

    @property
    def train_names(self) -> list[str]:
        """The training runs' names."""
        return [str(t["run"][0]) for t in self.train]

    @property
    def holdout_names(self) -> list[str]:
        """The held-out runs' names."""
        return [str(t["run"][0]) for t in self.holdout]


def open_dataset(dataset: DatasetLike) -> Dataset:
    """A campaign dataset to read.

    Parameters
    ----------
    dataset
        A :class:`Dataset`, or the folder ``thermrs extract REC… -o DATASET`` wrote.

    Returns
    -------
    Dataset
        The dataset (nothing is created on disk).

    Raises
    ------
    InputError
        No such folder, or not a campaign dataset.

    Examples
    --------
    >>> thermrs.analyses.inputs.open_dataset("campaign/").catalog()  # doctest: +SKIP
    """
    return dataset if isinstance(dataset, Dataset) else Dataset.open(Path(dataset))


def _names(runs: pl.DataFrame) -> list[str]:
    return [f"{a}#{b}" for a, b in zip(runs["recording"], runs["run"], strict=True)]


def pick_runs(runs: pl.DataFrame, names: Sequence[str], *, what: str = "run") -> pl.DataFrame:
    """The rows of ``runs`` (:func:`thermrs.campaigns.select.campaign_runs`) that ``names``
    name (see the module docs), in the order named, each once.

    Raises
    ------
    InputError
        A name that names no run of ``runs``, or whose stem is that of several recordings;
        the message names it and lists the runs there are.
    """
    ids = runs["recording"].unique().to_list()
    by_stem: dict[str, list[str]] = {}
    for rid in ids:
        by_stem.setdefault(_ID_HASH.sub("", rid), []).append(rid)
    every = _names(runs)
    picked: list[int] = []
    for name in names:
        rec, _, run = str(name).partition("#")
        rid = rec if rec in ids else None
        if rid is None and len(by_stem.get(rec, [])) > 1:
            raise InputError(
                f"{what} {name}: {len(by_stem[rec])} recordings of the campaign are called "
                f"{rec!r} ({', '.join(sorted(by_stem[rec]))}): name one by its id"
            )
        if rid is None and rec in by_stem:
            rid = by_stem[rec][0]
        rows = [
            i
            for i, r in enumerate(runs.iter_rows(named=True))
            if r["recording"] == rid and (not run or r["run"] == run)
        ]
        if not rows:
            shown = ", ".join(every[:8]) + (f", … ({len(every)} runs)" if len(every) > 8 else "")
            raise InputError(f"{what} {name}: no such run among the runs selected ({shown})")
        picked += [i for i in rows if i not in picked]
    return runs[picked]


def select_runs(
    dataset: DatasetLike, *, where: str | None = None, names: Sequence[str] = ()
) -> pl.DataFrame:
    """The runs chosen by query and, if ``names`` are given, by name among them.

    Parameters
    ----------
    dataset
        The campaign dataset (a :class:`Dataset` or its folder).
    where
        The query (:func:`thermrs.campaigns.select.parse_query`; default every run).
    names
        Runs by name (see the module docs).

    Returns
    -------
    polars.DataFrame
        One row per run, the columns of :func:`thermrs.campaigns.select.campaign_runs`.

    Raises
    ------
    InputError
        Not a dataset; a bad query, or one that matches no run; a name that names no run.

    Examples
    --------
    >>> thermrs.analyses.inputs.select_runs("campaign/", where="speed>20")  # doctest: +SKIP
    """
    runs = campaign_runs(open_dataset(dataset), where)
    return pick_runs(runs, names) if names else runs


def splits(
    dataset: DatasetLike,
    rig: Any,
    *,
    where: str | None = None,
    rule: str | None = None,
    train: Sequence[str] = (),
    holdout: Sequence[str] = (),
) -> list[Split]:
    """Training and held-out run tables of the runs ``where`` selects: a split per fold of
    ``rule``, or the one split ``train`` and ``holdout`` name (see the module docs).

    Parameters
    ----------
    dataset
        The campaign dataset.
    rig
        The rig (what the run tables' model columns need).
    where
        The query choosing runs (default every run).
    rule
        ``leave-one-run-out`` or ``by-day``; not with ``train`` or ``holdout``.
    train, holdout
        Run names (see the module docs).

    Returns
    -------
    list of Split
        One per fold of ``rule``; else one.

    Raises
    ------
    InputError
        What :func:`select_runs` and :func:`thermrs.campaigns.select.folds` raise; a rule
        together with names; a run both trained on and held out; nothing left to train on.

    Examples
    --------
    >>> for s in thermrs.analyses.splits("campaign/", rig, rule="leave-one-run-out"):
    ...     print(s.name, s.train_names, s.holdout_names)  # doctest: +SKIP
    """
    ds = open_dataset(dataset)
    runs = campaign_runs(ds, where)
    if rule is not None and (train or holdout):
        raise InputError(f"rule {rule}: give either a rule or --train/--holdout runs, not both")
    if rule is not None:
        sets = [(f.name, f.train, f.holdout) for f in folds(runs, rule)]
    else:
        tr = _names(pick_runs(runs, train, what="--train")) if train else []
        ho = _names(pick_runs(runs, holdout, what="--holdout")) if holdout else []
        both = sorted(set(tr) & set(ho))
        if both:
            raise InputError(f"run(s) {', '.join(both)} both trained on and held out")
        rest = [n for n in _names(runs) if n not in tr and n not in ho]
        if train and not holdout:
            ho = rest
        elif holdout and not train:
            tr = rest
        elif not train:
            tr = rest
        if not tr:
            raise InputError("no training run left: every selected run is held out")
        sets = [("", tr, ho)]
    return _load(ds, runs, rig, sets)


def selected(
    dataset: DatasetLike,
    rig: Any,
    *,
    where: str | None = None,
    names: Sequence[str] = (),
    what: str = "run",
) -> Split:
    """The run tables of the runs ``where`` selects (or the ``names`` among them).

    Parameters
    ----------
    dataset, where, names
        As :func:`select_runs`.
    rig
        The rig the runs were recorded on.
    what
        What a name is called in an error message (``--run``, say).

    Returns
    -------
    Split
        The run tables as its ``train``, none held out; ``data_loss`` from the catalog.

    Raises
    ------
    InputError
        What :func:`select_runs` raises; a run without a visit with a spot.

    Examples
    --------
    >>> s = thermrs.analyses.selected("campaign/", rig, where="date=2026-11-02")  # doctest: +SKIP
    >>> s.train_names  # doctest: +SKIP
    """
    ds = open_dataset(dataset)
    runs = campaign_runs(ds, where)
    rows = pick_runs(runs, names, what=what) if names else runs
    return _load(ds, runs, rig, [("", _names(rows), [])])[0]


def _load(
    ds: Dataset, runs: pl.DataFrame, rig: Any, sets: list[tuple[str, list[str], list[str]]]
) -> list[Split]:
    """The splits' run tables, each run read once."""
    needed = {n for _, a, b in sets for n in (*a, *b)}
    rows = runs.filter(pl.concat_str("recording", pl.lit("#"), "run").is_in(sorted(needed)))
    tables = dict(zip(_names(rows), run_tables(ds, rows, rig), strict=True))
    for n, t in tables.items():
        if t.height == 0:
            raise InputError(f"run {n} of dataset {ds.root}: no visit with a spot")
    lost = set(rows.filter(pl.col("losses") > 0)["recording"].to_list())
    return [
        Split(
            name,
            [tables[n] for n in a],
            [tables[n] for n in b],
            data_loss=any(n.partition("#")[0] in lost for n in (*a, *b)),
        )
        for name, a, b in sets
    ]


@dataclass(frozen=True)
class FileRead:
    """One file spec read (:func:`read_files`).

    Attributes
    ----------
    given
        The spec as given (``FILE`` or ``FILE#RUN``).
    what
        The option it was given with (``--train``).
    runs
        Its runs (:class:`thermrs.runs.RunTables`).
    """

    given: str
    what: str
    runs: Any


def read_files(
    paths: Sequence[str | os.PathLike[str]],
    rig: Any,
    what: str | Sequence[str],
    *,
    say: Say | None = None,
    step: Say | None = None,
    cache: dict[Any, Any] | None = None,
) -> Iterator[FileRead]:
    """The one loader of file specs: recordings or extracted tables (``FILE`` or
    ``FILE#RUN``), each read once, its runs named as every command names them.

    Parameters
    ----------
    paths
        The files (``FILE#RUN`` for one run of a file).
    rig
        The rig (a :class:`~thermrs.rig.Rig` or its file).
    what
        The option they were given with (``--train``), or one per path, for messages.
    say
        Told the runs found in each file, and once per file that it lost data.
    step
        Told ``reading FILE (i/n)`` before each file is read.
    cache
        Files already read by this caller (:func:`thermrs.runs.load_runs`'s ``cache``): a
        file named in two options is read once.

    Yields
    ------
    FileRead
        Each spec's runs, in the order given. Two files of one stem (``r30.mcap`` and
        ``r30.parquet``, or one name in two folders) name their runs by the paths given.

    Raises
    ------
    InputError
        A file given twice, unreadable, or a run without a visit with a spot (with a hint
        where the rig's poses look like radians).

    Examples
    --------
    >>> for f in thermrs.analyses.read_files(["rec.mcap"], rig, "--run"):  # doctest: +SKIP
    ...     print(f.runs.describe())
    """
    from thermrs.fit import run_name
    from thermrs.rig import as_rig
    from thermrs.runs import load_runs, split_run_spec

    r = as_rig(rig)
    given = [os.fspath(p) for p in paths]
    whats = [what] * len(given) if isinstance(what, str) else list(what)
    specs = [split_run_spec(p) for p in given]
    seen: set[str] = set()
    for p, w, (base, run) in zip(given, whats, specs, strict=True):
        key = f"{base.resolve()}#{run}"
        if key in seen:
            raise InputError(f"{w} {p}: given twice")
        seen.add(key)
    names = [run_name(base) for base, _ in specs]
    warned: set[Path] = set()
    for i, (p, w, (base, _), name) in enumerate(zip(given, whats, specs, names, strict=True)):
        if step is not None:
            step(f"reading {p} ({i + 1}/{len(given)})")
        same = any(n == name and b != base for (b, _), n in zip(specs, names, strict=True))
        rt = load_runs(p, r, name=str(base) if same else None, cache=cache)
        if say is not None:
            say(f"{w} {rt.describe()}")
        for t in rt.tables:
            if t.height == 0:
                raise InputError(f"{w} {p}: no visit with a spot" + radians_hint(r))
        if rt.data_loss and say is not None and base not in warned:
            say(
                f"data loss: {p}: part of the recording was lost (see `thermrs extract` for "
                "what); results use what was intact"
            )
        if rt.data_loss:
            warned.add(base)
        yield FileRead(p, w, rt)


def file_tables(
    paths: Sequence[str | os.PathLike[str]],
    rig: Any,
    what: str,
    *,
    say: Say | None = None,
    cache: dict[Any, Any] | None = None,
) -> tuple[list[pl.DataFrame], bool]:
    """Run tables of recordings or extracted tables (``FILE`` or ``FILE#RUN``), and whether
    any recording lost data (for extracted tables: as their Parquet metadata records).

    Parameters
    ----------
    paths, rig, what, say, cache
        As :func:`read_files`.

    Returns
    -------
    tuple of (list of polars.DataFrame, bool)
        The run tables, in the order given (a file's runs in its order), and whether any
        recording lost data.

    Raises
    ------
    InputError
        As :func:`read_files`.

    Examples
    --------
    >>> tables, loss = thermrs.analyses.file_tables(["rec.mcap"], rig, "--train")  # doctest: +SKIP
    """
    tables: list[pl.DataFrame] = []
    loss = False
    for f in read_files(paths, rig, what, say=say, cache=cache):
        tables.extend(f.runs.tables)
        loss |= f.runs.data_loss
    return tables, loss


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


def file_splits(
    train: Sequence[str | os.PathLike[str]],
    holdout: Sequence[str | os.PathLike[str]],
    rig: Any,
    *,
    holdout_what: str = "--holdout",
    say: Say | None = None,
    cache: dict[Any, Any] | None = None,
) -> list[Split]:
    """The one split of training and held-out files (:func:`file_tables`), checked
    (:func:`check_splits`).

    Parameters
    ----------
    train, holdout
        The files (``FILE#RUN`` for one run of a file).
    rig
        The rig (a :class:`~thermrs.rig.Rig` or its file).
    holdout_what
        The option the held-out files were given with, for messages.
    say, cache
        As :func:`file_tables`.

    Returns
    -------
    list of Split
        One split, named ``""``.

    Raises
    ------
    InputError
        What :func:`file_tables` raises; no held-out run, or one that is a training run again.

    Examples
    --------
    >>> (s,) = thermrs.analyses.file_splits(["rec.mcap#a"], ["rec.mcap#b"], rig)  # doctest: +SKIP
    >>> s.train_names, s.holdout_names  # doctest: +SKIP
    """
    tt, loss1 = file_tables(train, rig, "--train", say=say, cache=cache)
    th, loss2 = file_tables(holdout, rig, holdout_what, say=say, cache=cache)
    sets = [Split("", tt, th, loss1 or loss2)]
    check_splits(sets, holdout_what=holdout_what)
    return sets


def check_splits(sets: Sequence[Split], *, holdout_what: str = "--holdout") -> None:
    """Every split holds out a run, and none that is a training run again.

    Raises
    ------
    InputError
        One line saying which.
    """
    for s in sets:
        if not s.holdout:
            raise InputError(
                f"no held-out run: every run chosen trains; name them with {holdout_what} or "
                "hold them out by --rule"
            )
        distinct_runs(s.train, s.holdout, holdout_what)
