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


@pytest.fixture(scope="session")
def comma2k19(realdata: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The real comma2k19 minute packed into an MCAP recording (see ``tests/_comma2k19.py``)."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("_comma2k19", REPO_ROOT / "tests/_comma2k19.py")
    assert spec is not None
    assert spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    out = tmp_path_factory.mktemp("comma2k19") / "comma2k19.mcap"
    path: Path = module.pack(realdata, out)
    return path
