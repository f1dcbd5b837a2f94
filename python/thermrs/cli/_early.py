"""Ctrl-C while the CLI starts: installed before anything heavy is imported (see
:func:`thermrs.cli.app.main`, which hands Ctrl-C back to Python before any work)."""

from __future__ import annotations

import os
import signal
import sys


def interrupted_early(signum: int, frame: object) -> None:
    """Ctrl-C while the CLI starts (imports): stop at once with the one line of SPEC §7.
    Nothing has been written yet; :func:`main` hands Ctrl-C back to Python before any work."""
    sys.stderr.write("thermrs: interrupted\n")
    sys.stderr.flush()
    os._exit(130)


# Installed before anything heavy is imported, unless Ctrl-C is ignored (a background job).
def invoked_as_cli() -> bool:
    """Whether this process is the ``thermrs`` command (the console script or ``python -m
    thermrs``), not a program that imports the module (a test runner, a notebook)."""
    argv0 = os.path.basename(sys.argv[0]) if sys.argv and sys.argv[0] else ""
    return argv0 in ("thermrs", "__main__.py") and (
        argv0 == "thermrs" or os.path.basename(os.path.dirname(sys.argv[0])) == "thermrs"
    )


EARLY = signal.getsignal(signal.SIGINT) is signal.default_int_handler and invoked_as_cli()
if EARLY:
    signal.signal(signal.SIGINT, interrupted_early)
