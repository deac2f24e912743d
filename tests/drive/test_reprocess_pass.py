"""``drive.reprocess_pass``: the drive layer's one verb for ``slt reprocess``."""

from __future__ import annotations

from pathlib import Path

import pytest

from superlane_tools.drive import DriveOutcome, PassSetup, ReprocessConfig, reprocess_pass
from superlane_tools.drive.errors import DriveError
from superlane_tools.drive.loop import FrameSink
from superlane_tools.drive.stages import Finished
from superlane_tools.recording import open_recording
from superlane_tools.recording.tools import filter_recording
from superlane_tools.simulation.drive import simulate_drive

CFG = ReprocessConfig().with_overrides({"segmentation.backend": "classical"})
FRAMES = 8  # 0.5 s at 15 Hz


@pytest.fixture(scope="module")
def recording(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("pass") / "d.mcap"
    simulate_drive("highway_straight", FRAMES / 15.0, 1, "mcap", 320, 180, False, out)
    return out


class Opener:
    """Opens one counting sink per call and remembers the setup it was given."""

    def __init__(self) -> None:
        self.setups: list[PassSetup] = []
        self.added = 0

    def __call__(self, setup: PassSetup) -> list[FrameSink]:
        self.setups.append(setup)
        return [self]

    def add(self, done: Finished) -> None:
        self.added += 1

    def close(self, ok: bool) -> list[Path]:
        return [Path(f"frames-{self.added}")] if ok else []


def _pass(path: Path, opener: Opener, labels: list[str] | None = None) -> DriveOutcome:
    said = labels if labels is not None else []
    with open_recording(path) as rec:
        return reprocess_pass(rec, path, CFG, opener, {}, phase=said.append)


def test_a_camera_drive_is_resolved_then_passed_once(recording: Path) -> None:
    opener, labels = Opener(), []
    outcome = _pass(recording, opener, labels)
    assert len(opener.setups) == 1
    setup = opener.setups[0]
    assert setup.stages is not None
    assert setup.camera is not None
    assert setup.topics.frames
    assert setup.total == FRAMES
    assert outcome.setup is setup
    assert outcome.camera
    assert opener.added == outcome.camera_frames == FRAMES
    assert outcome.files == ((Path(f"frames-{FRAMES}"),),)
    assert labels == ["loading the segmentation model", "pass", "report: tables, plots, report"]
    assert len(outcome.derived.availability_frames) > 0
    methods = [row[0] for row in outcome.availability()]
    assert "super" in methods
    assert all(row[1] > 0 for row in outcome.availability())
    assert outcome.facts.recording == recording
    assert outcome.facts.n_frames == FRAMES
    outcome.clock.lap()
    assert {"pass_wall", "post", "total"} <= set(outcome.timings())


def test_without_a_camera_the_grid_stands_in_and_no_sink_opens(
    recording: Path, tmp_path: Path
) -> None:
    signals = tmp_path / "signals.mcap"
    filter_recording(recording, signals, exclude="image|camera")
    opener = Opener()
    outcome = _pass(signals, opener)
    assert opener.setups == []
    assert outcome.files == ()
    assert not outcome.camera
    assert outcome.camera_frames == 0
    assert len(outcome.frames) > 0  # 15 Hz instants over the signals' span
    assert outcome.availability() == ()
    assert outcome.facts.backend_name == "none (no camera stream)"
    outcome.clock.lap()
    assert set(outcome.timings()) == {"total"}


def test_nothing_to_reprocess_is_one_clear_error(recording: Path, tmp_path: Path) -> None:
    imu_only = tmp_path / "imu.mcap"
    filter_recording(recording, imu_only, exclude="image|camera|can|gnss|fix|gps|nav")
    with pytest.raises(DriveError, match="no camera, CAN or GNSS stream to reprocess"):
        _pass(imu_only, Opener())
