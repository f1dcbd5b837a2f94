"""Shared fixtures: the embedded paper rig, the shared folder beside the checkout, and Ctrl-C
as a terminal delivers it."""

from __future__ import annotations

import signal
from collections.abc import Iterator
from pathlib import Path

import pytest
import thermrs

REPO = Path(__file__).resolve().parents[1]
SHARED = REPO.parent / "shared"


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
