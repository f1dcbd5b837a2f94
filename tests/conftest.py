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

# Every test computes what it checks: no diagnosis comes from the user's on-disk cache (the
# cache's own tests give it a folder of their own).
os.environ["THERMRS_CACHE_DIR"] = "off"

# pytest-xdist's workers run with COLUMNS=80 and LINES=24 in their environment; the commands
# the tests start would take that for a terminal's width. A test that wants a width sets it.
if os.environ.get("PYTEST_XDIST_WORKER"):
    os.environ.pop("COLUMNS", None)
    os.environ.pop("LINES", None)


#: Test files that take minutes (a simulated demo, a designed experiment, long scenarios), run
#: first: with every core busy, the suite then ends on the many short files, not one long one.
LONG_FILES = (
    "test_report.py",
    "test_design.py",
    "test_readme.py",
    "test_effect_residuals.py",
    "test_fit.py",
    "test_simulate.py",
    "test_campaign.py",
    "test_campaign_commands.py",
)


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    rank = {name: i for i, name in enumerate(LONG_FILES)}
    items.sort(key=lambda it: rank.get(it.path.name, len(LONG_FILES)))


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
