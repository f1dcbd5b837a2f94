"""The runs a report is on, read from files: each ``--train``/``--run`` spec once, its runs
named as every command names them (by path when two files share a name), a run read twice
kept once, and which of them α is fitted on.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from thermrs.report.data import RunInput, Step, load_runs
from thermrs.rig import Rig

__all__ = ["ReportRuns", "SpecRead", "read_report_runs"]


@dataclass(frozen=True)
class SpecRead:
    """What one spec gave: its file, its runs, whether it was a training spec, and whether it
    is the first spec of that file to report lost data (warn once per file)."""

    spec: Path
    file: Path
    runs: list[RunInput]
    train: bool
    new_loss: bool


@dataclass
class ReportRuns:
    """The report's runs (each once, in the order read), the training runs' names and whether
    any recording lost data."""

    runs: list[RunInput] = field(default_factory=list)
    train: list[str] = field(default_factory=list)
    data_loss: bool = False


def read_report_runs(
    train: Sequence[Path],
    runs: Sequence[Path],
    rig: Rig,
    *,
    step: Step | None = None,
    read: Callable[[SpecRead], None] | None = None,
) -> ReportRuns:
    """Read the ``train`` then the ``runs`` specs (a spec given twice read once).

    Parameters
    ----------
    train, runs
        ``FILE`` or ``FILE#RUN`` specs (see :func:`thermrs.report.data.load_runs`).
    rig
        The rig they were recorded on.
    step
        Told ``reading SPEC (i/n)`` before each spec is read.
    read
        Told what each spec gave, once read.

    Raises
    ------
    InputError
        As :func:`thermrs.report.data.load_runs`.
    """
    from thermrs.fit import run_name
    from thermrs.runs import split_run_spec

    specs = list(dict.fromkeys([*train, *runs]))
    files = [split_run_spec(p)[0] for p in specs]
    names = [run_name(f) for f in files]
    cache: dict[object, object] = {}
    out = ReportRuns()
    for i, (p, f) in enumerate(zip(specs, files, strict=True)):
        if step is not None:
            step(f"reading {p} ({i + 1}/{len(specs)})")
        # Two files of one name in different folders: name the runs by their paths.
        same = any(n == names[i] and g != f for n, g in zip(names, files, strict=True))
        got = load_runs(p, rig, name=str(f) if same else None, cache=cache)
        lost = any(r.data_loss for r in got)
        if read is not None:
            read(SpecRead(p, f, got, p in train, lost and f not in files[:i]))
        out.data_loss |= lost
        for r in got:
            if r.name in {x.name for x in out.runs}:
                continue
            out.runs.append(r)
            if p in train:
                out.train.append(r.name)
    return out
