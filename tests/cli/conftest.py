"""Fixtures of the CLI tests: the recordings and renderers of the layers' own test folders."""

from __future__ import annotations

import importlib.util
from pathlib import Path
from types import ModuleType

TESTS = Path(__file__).resolve().parents[1]


def _load(rel: str, name: str) -> ModuleType:
    spec = importlib.util.spec_from_file_location(name, TESTS / rel)
    assert spec is not None
    assert spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


_batch = _load("commands/batch/conftest.py", "_cli_batch_fixtures")
_recording = _load("recording/conftest.py", "_cli_recording_fixtures")
_lanes = _load("lanes/conftest.py", "_cli_lanes_fixtures")

make_drives = _batch.make_drives
write_corrupt = _batch.write_corrupt
drive = _recording.drive
renderer = _lanes.renderer
camera_factory = _lanes.camera_factory
