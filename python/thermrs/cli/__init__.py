"""The ``thermrs`` command line: a thin layer over the library API.

Exit codes (SPEC §7): 0 success; 2 bad input or usage (one line on stderr, no traceback);
3 finished with data loss; 1 internal error (set ``THERMRS_DEBUG=1`` for the traceback);
130 interrupted (Ctrl-C).

Start-up is kept short (``thermrs --help``): numpy, polars, scipy and matplotlib are imported
inside the commands that need them, never at module level. Two modules do load at start-up:
rich (:mod:`thermrs.cli.design`, :mod:`~thermrs.cli.diagnose` and :mod:`~thermrs.cli.report`
import its tables and consoles at module level) and the Rust extension ``thermrs._native``,
which defines the exception classes of :mod:`thermrs.errors` that every command maps to an
exit code.

One module of this package per command (``thermrs.cli.<command>``; ``diagnose-bench`` beside
``diagnose``), each only parsing and rendering; the library computes.
:mod:`thermrs.cli.common` holds the shared options, output checks and tables,
:mod:`thermrs.cli.app` the group and the entry point :func:`main`.
Another module adds a command with ``cli.add_command(my_command)`` (a ``click.Command``).
"""

from __future__ import annotations

# First: Ctrl-C while the CLI starts exits at once (before the heavy imports below).
from thermrs.cli import _early  # noqa: F401  isort: skip
from thermrs.cli.app import cli, main
from thermrs.cli.common import (
    EXIT_BAD_INPUT,
    EXIT_DATA_LOSS,
    EXIT_INTERNAL,
    EXIT_INTERRUPTED,
    EXIT_OK,
    VISIT_TOLERANCE_DEG,
    console,
    input_file,
    out,
    out_option,
    rig_option,
    run_file,
    runs_option,
    table,
    writable,
)

__all__ = [
    "EXIT_BAD_INPUT",
    "EXIT_DATA_LOSS",
    "EXIT_INTERNAL",
    "EXIT_INTERRUPTED",
    "EXIT_OK",
    "VISIT_TOLERANCE_DEG",
    "cli",
    "console",
    "input_file",
    "main",
    "out",
    "out_option",
    "rig_option",
    "run_file",
    "runs_option",
    "table",
    "writable",
]


def _register() -> None:
    """One command per module."""
    from thermrs.cli.campaign import campaign_command
    from thermrs.cli.compensate import compensate
    from thermrs.cli.design import design
    from thermrs.cli.diagnose import diagnose, diagnose_bench
    from thermrs.cli.drift import drift
    from thermrs.cli.extract import extract
    from thermrs.cli.fit import fit
    from thermrs.cli.info import info
    from thermrs.cli.paper import paper
    from thermrs.cli.predict import predict
    from thermrs.cli.report import report
    from thermrs.cli.rig import rig
    from thermrs.cli.simulate import simulate
    from thermrs.cli.watch import watch

    for command in (paper, rig, info, extract, simulate, fit, predict, compensate, drift,
                    diagnose, design, diagnose_bench, report, campaign_command, watch):  # fmt: skip
        cli.add_command(command)


_register()
