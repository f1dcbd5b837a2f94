"""The command line as a user meets it: ``python -m thermrs`` in a child process, and what a
finished command must have said (exit 0; or bad input: exit 2 with one error line)."""

from __future__ import annotations

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
