"""The command group and the entry point: run a command and map what happens to SPEC §7 exit
codes (0 success; 2 bad input or usage, one line; 3 finished with data loss; 1 internal
error, ``THERMRS_DEBUG=1`` for the traceback; 130 interrupted)."""

from __future__ import annotations

import os
import signal
import sys
import traceback
from typing import Any

import click

from thermrs.cli._early import EARLY, interrupted_early, invoked_as_cli
from thermrs.cli.common import EXIT_BAD_INPUT, EXIT_INTERNAL, EXIT_INTERRUPTED
from thermrs.errors import ThermrsError


class _Interrupted(Exception):
    """Ctrl-C, carried past click (which would print an empty line first); its message, if
    any, is what the interrupted command had done (the ``KeyboardInterrupt``'s)."""


class ThermrsGroup(click.Group):
    """The command group; every command, including those other modules add with
    ``cli.add_command``, runs through :meth:`invoke`."""

    def invoke(self, ctx: click.Context) -> Any:
        try:
            return super().invoke(ctx)
        except KeyboardInterrupt as e:
            raise _Interrupted(str(e)) from None


@click.group(cls=ThermrsGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="thermrs")
def cli() -> None:
    """Measure, model and predict the temperature-induced drift of industrial robots."""


#: Options that take several values (``--train A B``) as well as repeats (``--train A
#: --train B``), as SPEC §7 and the issues write them (``--between E1 E2 …``).
MULTI_VALUE_OPTIONS = (
    "--train",
    "--holdout",
    "--run",
    "--exclude",
    "--between",
    "--effect",
    "--world",
    "--snr",
    "--check",
)


def expand_multi(argv: list[str]) -> list[str]:
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


def _exit_interrupted(detail: str = "") -> None:
    """One line (``thermrs: interrupted``, and ``: detail`` where the command said how far it
    got), exit 130, at once: the stack has unwound (temporary files are gone); nothing in the
    interpreter's shutdown may turn this into another exit status."""
    click.echo("thermrs: interrupted" + (f": {detail}" if detail else ""), err=True)
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(EXIT_INTERRUPTED)


def main(argv: list[str] | None = None) -> None:
    """Entry point: run the CLI and map errors to SPEC §7 exit codes.

    Anything unexpected (a Python exception, or a Rust panic: pyo3's ``PanicException`` is a
    ``BaseException``) exits 1 with one line; ``THERMRS_DEBUG=1`` adds the traceback.
    """
    from thermrs.errors import InternalError, OutputError

    if EARLY and signal.getsignal(signal.SIGINT) is interrupted_early:
        # From here Ctrl-C raises KeyboardInterrupt, so that whatever is being written is
        # removed on the way out (and the Rust loops see it between chunks).
        signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        args = sys.argv[1:] if argv is None else argv
        cli.main(args=expand_multi(list(args)), prog_name="thermrs", standalone_mode=False)
        if invoked_as_cli():
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
    except (KeyboardInterrupt, _Interrupted) as e:
        _exit_interrupted(str(e))
    except click.exceptions.Abort:
        _exit_interrupted()
    except OutputError as e:  # an output the system would not take (full disk): exit 1
        click.echo(f"thermrs: error: {e}", err=True)
        sys.exit(EXIT_INTERNAL)
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
