"""Stream helpers on a real recording (the sample drive): time ranges, message totals, types."""

from __future__ import annotations

from pathlib import Path

from superlane_tools.recording.base import time_range_ns
from superlane_tools.recording.open import open_recording
from superlane_tools.recording.streams import message_total, topics_of_type

SAMPLE = Path(__file__).resolve().parents[2] / "fixtures" / "sample_drive.mcap"


def test_time_range_counts_from_the_first_message_of_the_topics() -> None:
    with open_recording(SAMPLE) as rec:
        frames = topics_of_type(rec.topics(), "sensor_msgs/msg/CompressedImage")
        assert frames == {"/camera/image/compressed"}
        first = next(m.log_time_ns for m in rec.raw_messages(topics=frames))
        assert time_range_ns(rec, frames, None, None) == (None, None)
        assert time_range_ns(rec, frames, 1.5, None) == (first + 1_500_000_000, None)
        assert time_range_ns(rec, frames, None, 2.0) == (None, first + 2_000_000_000)
        assert time_range_ns(rec, {"/absent"}, 1.0, 2.0) == (None, None)


def test_message_total_is_unknown_when_a_count_is() -> None:
    with open_recording(SAMPLE) as rec:
        topics = rec.topics()
        frames = topics_of_type(topics, "sensor_msgs/msg/CompressedImage")
        n_frames = message_total(topics, frames)
        assert n_frames == 240  # 16 s at 15 Hz
        both = frames | topics_of_type(topics, "can_msgs/msg/Frame")
        total = message_total(topics, both)
        assert total is not None
        assert total > n_frames
    unknown = [t._replace(message_count=None) for t in topics]
    assert message_total(unknown, frames) is None
    assert message_total(topics, set()) == 0
