"""Reprocess runs of short simulated drives, made once per session for compare and mine tests.

The runs use the oracle segmentation (the simulator's label images), so they are quick and
deterministic: ``base`` and ``repeat`` are the same run twice; ``blind`` sees blank label
images in frames :data:`BLIND_FRAMES` (no road, no markings), so SUPER fails there and only
there: a drive built to have one disagreement span.
"""

from __future__ import annotations

import shutil
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from superlane_tools.commands.reprocess import reprocess
from superlane_tools.drive.config import ReprocessConfig
from superlane_tools.reporting.run_folder import staged_run
from superlane_tools.simulation.drive import simulate_drive

BLIND_FRAMES = range(20, 44)
"""Frames (of 60) whose oracle labels the ``blind`` run gets blank."""


@dataclass(frozen=True)
class OracleRuns:
    """The recording and its run folders, each under its own fleet folder.

    The ``base`` fleet also holds ``short``, a run of another (1.5 s) drive that the other
    fleets lack.
    """

    recording: Path
    blind_frames: range
    base: Path
    short: Path
    repeat: Path
    blind: Path


def _config(labels: Path) -> ReprocessConfig:
    return ReprocessConfig().with_overrides(
        {
            "segmentation.backend": "oracle",
            "segmentation.oracle_labels": str(labels),
            "kpi.window_s": 0.25,
            "output.plots": False,
            "output.example_frames": 0,
        }
    )


@pytest.fixture(scope="session")
def oracle_config() -> Callable[[Path], ReprocessConfig]:
    """The runs' configuration for oracle label images under a folder (for tests' own drives)."""
    return _config


@pytest.fixture(scope="session")
def oracle_runs(tmp_path_factory: pytest.TempPathFactory) -> OracleRuns:
    """A 4 s highway drive at 320x180 reprocessed three times (see the module docstring)."""
    import cv2

    root = tmp_path_factory.mktemp("fleet")
    rec = root / "drives" / "curves.mcap"
    rec.parent.mkdir()
    simulate_drive("highway_curves", 4.0, 3, "mcap", 320, 180, True, rec)
    labels = root / "drives" / "curves_labels" / "labels"
    blind = root / "blind_labels"
    shutil.copytree(labels, blind)
    for k in BLIND_FRAMES:
        path = blind / f"{k:06d}.png"
        cv2.imwrite(str(path), np.zeros_like(cv2.imread(str(path), cv2.IMREAD_UNCHANGED)))
    runs = {}
    for name, folder in (("base", labels), ("repeat", labels), ("blind", blind)):
        out = root / name / "curves"
        with staged_run(out) as stage:  # as the CLI does: complete runs carry a manifest
            result = reprocess(rec, stage, _config(folder), command=f"test {name}")
        assert result.frames == 60
        runs[name] = out
    short = root / "drives" / "short.mcap"
    simulate_drive("highway_straight", 1.5, 4, "mcap", 320, 180, True, short)
    with staged_run(root / "base" / "short") as stage:
        reprocess(short, stage, _config(root / "drives" / "short_labels" / "labels"))
    return OracleRuns(
        rec, BLIND_FRAMES, runs["base"], root / "base" / "short", runs["repeat"], runs["blind"]
    )
