"""Shared pytest fixtures: the real-data folder and small helpers."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

REPO_ROOT = Path(__file__).resolve().parents[1]


def realdata_root() -> Path:
    """Return the real-data folder: ``$SLT_REALDATA`` or ``../shared/data`` beside the repo."""
    env = os.environ.get("SLT_REALDATA")
    return Path(env) if env else REPO_ROOT.parent / "shared" / "data"


@pytest.fixture(scope="session")
def realdata() -> Path:
    """Real public data for tests; skip the test when the folder is absent."""
    root = realdata_root()
    if not (root / "README.md").is_file():
        pytest.skip(f"real data not found at {root} (set SLT_REALDATA)")
    return root
