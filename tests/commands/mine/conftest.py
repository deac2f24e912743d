"""Simulated drives with known bad frames, reprocessed with the oracle segmentation.

A bad frame is one whose oracle label image is blank (no road, no markings): SUPER finds no
lane there and only there, so the frames a miner should pick are known exactly.
"""

from __future__ import annotations

import shutil
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from superlane_tools.commands.reprocess import reprocess
from superlane_tools.drive.config import ReprocessConfig
from superlane_tools.reporting.run_folder import staged_run
from superlane_tools.simulation.drive import simulate_drive


@dataclass(frozen=True)
class BadDrive:
    """A simulated recording, its ground truth and a run of it whose ``bad`` frames are blind."""

    recording: Path
    truth: Path
    labels: Path
    run: Path
    frames: int
    bad: tuple[int, ...]


def blind_labels(labels: Path, out: Path, bad: Sequence[int]) -> Path:
    """Copy an oracle label folder with the label images of frames ``bad`` blanked."""
    import cv2

    shutil.copytree(labels, out)
    for k in bad:
        path = out / f"{k:06d}.png"
        cv2.imwrite(str(path), np.zeros_like(cv2.imread(str(path), cv2.IMREAD_UNCHANGED)))
    return out


def bad_drive(
    root: Path,
    config: Callable[[Path], ReprocessConfig],
    name: str,
    size: tuple[int, int],
    seconds: float,
    fps: float,
    bad: Sequence[int],
    video: str | None = None,
) -> BadDrive:
    """Simulate ``highway_curves`` (seed 5), reprocess it with frames ``bad`` blind."""
    rec = root / "drives" / f"{name}.mcap"
    rec.parent.mkdir(parents=True, exist_ok=True)
    result = simulate_drive(
        "highway_curves", seconds, 5, "mcap", size[0], size[1], True, rec, fps=fps, video=video
    )
    labels = root / "drives" / f"{name}_labels" / "labels"
    blind = blind_labels(labels, root / f"{name}_blind", bad)
    out = root / "runs" / name
    with staged_run(out) as stage:
        frames = reprocess(rec, stage, config(blind), command=f"test {name}").frames
    assert frames == result.frames
    truth = root / "drives" / f"{name}.tusimple.json"
    return BadDrive(rec, truth, labels, out, frames, tuple(bad))


@pytest.fixture(scope="session")
def make_bad_drive() -> Callable[..., BadDrive]:
    """:func:`bad_drive`, for the tests' own drives."""
    return bad_drive


@pytest.fixture(scope="session")
def make_blind_labels() -> Callable[[Path, Path, Sequence[int]], Path]:
    """:func:`blind_labels`, for the tests' own runs."""
    return blind_labels
