"""Shared fixtures: the embedded paper rig, the shared folder beside the checkout, and Ctrl-C
as a terminal delivers it."""

from __future__ import annotations

import os
import signal
from collections.abc import Iterator
from pathlib import Path

import pytest
import thermrs

REPO = Path(__file__).resolve().parents[1]
SHARED = REPO.parent / "shared"

# pytest-xdist's workers run with COLUMNS=80 and LINES=24 in their environment; the commands
# the tests start would take that for a terminal's width. A test that wants a width sets it.
if os.environ.get("PYTEST_XDIST_WORKER"):
    os.environ.pop("COLUMNS", None)
    os.environ.pop("LINES", None)


@pytest.fixture(scope="session")
def paper_rig() -> thermrs.Rig:
    return thermrs.load_rig()


@pytest.fixture(scope="session")
def shared() -> Path:
    if not SHARED.is_dir():
        pytest.skip(f"shared folder not found at {SHARED}")
    return SHARED


@pytest.fixture
def sigint_raises() -> Iterator[None]:
    """SIGINT raises ``KeyboardInterrupt`` in this process for the test, as in a terminal,
    whatever the process inherited: a shell that runs the suite in the background, ``nohup``
    and some CI runners start it with SIGINT ignored, and then ``signal.raise_signal``
    does nothing at all."""
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
