"""The frame loop: every frame in order into every sink, sinks closed once, errors discard."""

from __future__ import annotations

from pathlib import Path

import pytest

from superlane_tools.drive import (
    DriveTopics,
    FrameStages,
    FrameTablesSink,
    ReprocessConfig,
    drive_topics,
    run_frames,
)
from superlane_tools.drive.stages import Finished
from superlane_tools.recording import open_recording
from superlane_tools.recording.calibration import resolve_camera
from superlane_tools.reporting import Provenance
from superlane_tools.reporting.layout import RunLayout
from superlane_tools.simulation.drive import simulate_drive

CFG = ReprocessConfig().with_overrides({"segmentation.backend": "classical"})
FRAMES = 8  # 0.5 s at 15 Hz


@pytest.fixture(scope="module")
def recording(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("loop") / "d.mcap"
    simulate_drive("highway_straight", FRAMES / 15.0, 1, "mcap", 320, 180, False, out)
    return out


class Taker:
    """A sink that notes what it was given; fails at frame ``fail_at``."""

    def __init__(self, fail_at: int = -1) -> None:
        self.indices: list[int] = []
        self.closed: list[bool] = []
        self.fail_at = fail_at

    def add(self, done: Finished) -> None:
        if done.prepared.index == self.fail_at:
            raise RuntimeError("sink failed")
        self.indices.append(done.prepared.index)

    def close(self, ok: bool) -> list[Path]:
        self.closed.append(ok)
        return [Path(f"taker-{len(self.indices)}")] if ok else []


def _stages(rec: object, topics: DriveTopics) -> FrameStages:
    camera, _ = resolve_camera(rec, topics.streams, CFG.camera)  # type: ignore[arg-type]
    return FrameStages(CFG, camera)


def test_every_frame_reaches_every_sink_in_order(recording: Path, tmp_path: Path) -> None:
    layout = RunLayout(tmp_path)
    with open_recording(recording) as rec:
        topics = drive_topics(rec, CFG.topics)
        stages = _stages(rec, topics)
        tables = FrameTablesSink(layout.streamed(), Provenance(), "", 3)
        first, second = Taker(), Taker()
        progress: list[tuple[int, int | None]] = []
        drive = run_frames(
            rec, topics, stages, [first, tables, second], 2, lambda d, t: progress.append((d, t))
        )
    assert first.indices == second.indices == list(range(FRAMES))
    assert first.closed == second.closed == [True]
    assert drive.files[0] == (Path(f"taker-{FRAMES}"),)
    assert drive.files[1] == tuple(layout.streamed().values())
    assert all(p.is_file() for p in drive.files[1])
    assert len(drive.frames) == FRAMES
    assert progress[-1] == (FRAMES, FRAMES)
    assert len(drive.can) > 0
    assert len(drive.gnss.log_time_ns) > 0
    assert drive.failed == ()
    assert drive.span_ns is None  # only measured without a camera


def test_a_failing_sink_discards_every_output(recording: Path, tmp_path: Path) -> None:
    layout = RunLayout(tmp_path)
    with open_recording(recording) as rec:
        topics = drive_topics(rec, CFG.topics)
        tables = FrameTablesSink(layout.streamed(), Provenance(), "", 3)
        other, failing = Taker(), Taker(fail_at=2)
        with pytest.raises(RuntimeError, match="sink failed"):
            run_frames(rec, topics, _stages(rec, topics), [other, tables, failing])
    assert other.indices == [0, 1, 2]  # frame 2 reached it before the failing sink
    assert other.closed == failing.closed == [False]
    assert list(tmp_path.iterdir()) == []  # the streamed tables were discarded


def test_without_stages_only_signals_are_collected(recording: Path) -> None:
    with open_recording(recording) as rec:
        topics = drive_topics(rec, CFG.topics)
        sink = Taker()
        drive = run_frames(rec, topics, None, [sink])
    assert sink.indices == []
    assert sink.closed == [True]
    assert len(drive.frames) == 0
    assert len(drive.can) > 0
    assert drive.span_ns is not None
    assert drive.span_ns[0] < drive.span_ns[1]
