"""MCAP metadata records from the project's writer, read back with mcap's own reader."""

from __future__ import annotations

import pytest
from mcap.reader import make_reader

from superlane_tools.recording import RecordingError, open_writer
from superlane_tools.recording.messages import can_frame


def test_mcap_metadata_round_trip(tmp_path):
    path = tmp_path / "m.mcap"
    with open_writer(path, "mcap") as writer:
        writer.add_topic("/can", "can_msgs/msg/Frame")
        writer.add_metadata("slt_camera", {"height_m": 1.5, "pitch_rad": "0.06"})
        writer.write("/can", 1_000, can_frame(1_000, 0x180, b"\x01\x02"))
    with path.open("rb") as handle:
        records = list(make_reader(handle).iter_metadata())
    assert [(r.name, r.metadata) for r in records] == [
        ("slt_camera", {"height_m": "1.5", "pitch_rad": "0.06"})
    ]


def test_bag_formats_refuse_metadata(tmp_path):
    with open_writer(tmp_path / "b.bag", "ros1") as writer, pytest.raises(RecordingError):
        writer.add_metadata("slt_camera", {"a": "b"})
