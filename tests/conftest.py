"""Shared fixtures: the embedded paper rig and the shared folder beside the checkout."""

from __future__ import annotations

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
