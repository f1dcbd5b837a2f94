"""The command line as a user meets it: ``python -m thermrs`` in a child process, and what a
finished command must have said (exit 0; or bad input: exit 2 with one error line).

:func:`cli_in_process` runs the same entry point (:func:`thermrs.cli.app.main`, which maps
every error to its exit code and line) in this process, for tables of many bad inputs whose
subject is the message, not the process: the child's start (its imports, about half a second
each) is covered by the tests that use :func:`cli`."""

from __future__ import annotations

import contextlib
import io
import os
import subprocess
import sys
from pathlib import Path


def cli(
    *args: str, env: dict[str, str] | None = None, cwd: Path | None = None
) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "thermrs", *args],
        capture_output=True,
        text=True,
        env={**os.environ, "THERMRS_DEBUG": "", **(env or {})},
        cwd=cwd,
    )


def cli_in_process(*args: str) -> subprocess.CompletedProcess[str]:
    """``thermrs ARGS…`` through the console script's entry point in this process: its exit
    code, stdout and stderr, as :func:`cli` gives them (``THERMRS_DEBUG`` unset)."""
    from thermrs.cli.app import main

    out, err = io.StringIO(), io.StringIO()
    debug = os.environ.pop("THERMRS_DEBUG", None)
    code: int | str | None = 0
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            main(list(args))
    except SystemExit as e:
        code = e.code
    finally:
        if debug is not None:
            os.environ["THERMRS_DEBUG"] = debug
    rc = code if isinstance(code, int) else (0 if code is None else 1)
    return subprocess.CompletedProcess(
        ["thermrs", *args], rc, stdout=out.getvalue(), stderr=err.getvalue()
    )


def ok(p: subprocess.CompletedProcess[str]) -> subprocess.CompletedProcess[str]:
    assert p.returncode == 0, p.stderr
    return p


def bad(p: subprocess.CompletedProcess[str], *words: str) -> str:
    assert p.returncode == 2, (p.returncode, p.stderr)
    # Besides the runs each file was found to hold (one line per file), one error line.
    lines = [ln for ln in p.stderr.strip().splitlines() if not ln.startswith("thermrs: --")]
    assert len(lines) == 1 and "Traceback" not in p.stderr, p.stderr
    for w in words:
        assert w in lines[0], (w, lines[0])
    return lines[0]


def interruptible(
    *args: str,
    env: dict[str, str] | None = None,
    cwd: Path | None = None,
    new_session: bool = False,
) -> subprocess.Popen[str]:
    """``thermrs ARGS…`` started in a child that takes SIGINT as a terminal's Ctrl-C would.

    A suite started in the background (``nohup``, ``&``, some CI runners) has SIGINT ignored,
    and children inherit that: a Ctrl-C test would wait for an exit that never comes. The
    reset runs in the child before it becomes thermrs (no ``preexec_fn``: this process has
    threads). ``new_session``: a process group of its own, as a terminal's job is."""
    reset = (
        "import os, signal, sys; signal.signal(signal.SIGINT, signal.SIG_DFL); "
        "signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT}); "
        "os.execv(sys.executable, [sys.executable, '-m', 'thermrs', *sys.argv[1:]])"
    )
    return subprocess.Popen(
        [sys.executable, "-c", reset, *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, "THERMRS_DEBUG": "", **(env or {})},
        cwd=cwd,
        start_new_session=new_session,
    )
