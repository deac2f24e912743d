"""Damaged and unusual MCAP files: truncation, corrupt chunks, protobuf, JSON, non-recordings."""

from __future__ import annotations

import json
from pathlib import Path
from types import SimpleNamespace

import pytest

from superlane_tools.recording import RecordingError, open_recording, write_protobuf_mcap


def _chunk_indexes(path: Path) -> list:  # type: ignore[type-arg]
    from mcap.reader import make_reader

    with path.open("rb") as handle:
        summary = make_reader(handle).get_summary()
    assert summary is not None
    return sorted(summary.chunk_indexes, key=lambda ci: ci.chunk_start_offset)


def test_truncated_mcap_yields_everything_before_the_cut(
    drive: SimpleNamespace, tmp_path: Path
) -> None:
    path = drive.write("full.mcap", "mcap", chunk_size=4096)
    chunks = _chunk_indexes(path)
    assert len(chunks) >= 5
    cut_chunk = chunks[3]
    cut_at = cut_chunk.chunk_start_offset + cut_chunk.chunk_length // 2
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(path.read_bytes()[:cut_at])
    with open_recording(path) as rec:
        expected = [m for m in rec.messages() if m.log_time_ns < cut_chunk.message_start_time]
    with open_recording(cut) as rec:
        got = list(rec.messages())
        skipped = rec.skipped
    assert [(m.topic, m.log_time_ns) for m in got] == [(m.topic, m.log_time_ns) for m in expected]
    assert got[-1].data is not None
    assert [s.what for s in skipped] == ["truncated file"]


def test_corrupt_chunk_is_skipped_and_later_chunks_still_read(
    drive: SimpleNamespace, tmp_path: Path
) -> None:
    path = drive.write("full.mcap", "mcap", chunk_size=4096)
    chunks = _chunk_indexes(path)
    bad = chunks[2]
    data = bytearray(path.read_bytes())
    middle = bad.chunk_start_offset + bad.chunk_length // 2
    for i in range(middle, middle + 16):
        data[i] ^= 0xFF
    broken = tmp_path / "broken.mcap"
    broken.write_bytes(bytes(data))
    with open_recording(path) as rec:
        everything = list(rec.raw_messages())
    with open_recording(broken) as rec:
        got = list(rec.messages())
        skipped = rec.skipped
    in_bad = [
        m for m in everything if bad.message_start_time <= m.log_time_ns <= bad.message_end_time
    ]
    assert len(got) == len(everything) - len(in_bad)
    assert got[-1].log_time_ns == everything[-1].log_time_ns  # chunks after the bad one were read
    assert [(s.what, s.n_items) for s in skipped] == [("corrupt chunk", len(in_bad))]


def test_corrupt_chunk_in_a_file_without_footer(drive: SimpleNamespace, tmp_path: Path) -> None:
    path = drive.write("full.mcap", "mcap", chunk_size=4096)
    chunks = _chunk_indexes(path)
    data = bytearray(path.read_bytes()[: chunks[-1].chunk_start_offset])  # drop the last chunk on
    middle = chunks[1].chunk_start_offset + chunks[1].chunk_length // 2
    data[middle : middle + 8] = bytes(8)
    damaged = tmp_path / "damaged.mcap"
    damaged.write_bytes(bytes(data))
    with open_recording(damaged) as rec:
        got = list(rec.messages())
        kinds = sorted(s.what for s in rec.skipped)
    assert kinds == ["corrupt chunk", "truncated file"]
    assert got
    times = [m.log_time_ns for m in got]
    assert times == sorted(times)
    assert times[-1] < chunks[-1].message_start_time


def test_foxglove_protobuf_mcap(tmp_path: Path) -> None:
    from foxglove_schemas_protobuf.CompressedImage_pb2 import CompressedImage
    from foxglove_schemas_protobuf.LocationFix_pb2 import LocationFix
    from google.protobuf.timestamp_pb2 import Timestamp

    items = []
    for i in range(5):
        t = 1_700_000_000_000_000_000 + i * 50_000_000
        stamp = Timestamp(seconds=t // 10**9, nanos=t % 10**9 - 1_000_000 if t % 10**9 else 0)
        items.append(
            (
                "/cam",
                t,
                CompressedImage(
                    timestamp=stamp, frame_id="cam", format="jpeg", data=bytes([i]) * 10
                ),
            )
        )
        items.append(("/gps", t + 1, LocationFix(latitude=48.0 + i, longitude=11.0)))
    path = write_protobuf_mcap(tmp_path / "fox.mcap", items)
    again = write_protobuf_mcap(tmp_path / "fox2.mcap", items)
    assert path.read_bytes() == again.read_bytes()
    with open_recording(path) as rec:
        assert {t.topic: (t.msgtype, t.encoding, t.message_count) for t in rec.topics()} == {
            "/cam": ("foxglove.CompressedImage", "protobuf", 5),
            "/gps": ("foxglove.LocationFix", "protobuf", 5),
        }
        msgs = list(rec.messages())
        raw = next(iter(rec.raw_messages(topics=["/cam"])))
        assert rec.peek_stamp_ns(raw) == msgs[0].stamp_ns  # type: ignore[attr-defined]
    cams = [m for m in msgs if m.topic == "/cam"]
    assert [bytes(m.data.data)[:1] for m in cams] == [bytes([i]) for i in range(5)]
    assert cams[1].stamp_ns == items[2][1] - 1_000_000
    gps = [m for m in msgs if m.topic == "/gps"]
    assert gps[2].data.latitude == 50.0
    assert gps[2].stamp_ns is None  # LocationFix written without a timestamp


def test_json_mcap(tmp_path: Path) -> None:
    from mcap.writer import Writer

    path = tmp_path / "j.mcap"
    with path.open("wb") as handle:
        writer = Writer(handle)
        writer.start(profile="", library="test")
        schema = writer.register_schema("speed", "jsonschema", b'{"type": "object"}')
        channel = writer.register_channel("/speed", "json", schema)
        for i in range(4):
            body = {"header": {"stamp": {"sec": 100 + i, "nanosec": 5}}, "speed_mps": 10.0 + i}
            writer.add_message(channel, 100 * 10**9 + i * 10**9 + 7, json.dumps(body).encode(), 0)
        writer.finish()
    with open_recording(path) as rec:
        msgs = list(rec.messages())
    assert [m.data.speed_mps for m in msgs] == [10.0, 11.0, 12.0, 13.0]
    assert [m.stamp_ns for m in msgs] == [(100 + i) * 10**9 + 5 for i in range(4)]
    assert msgs[0].msgtype == "speed"


def test_unknown_schema_is_skipped_per_topic(tmp_path: Path) -> None:
    from mcap.writer import Writer

    path = tmp_path / "u.mcap"
    with path.open("wb") as handle:
        writer = Writer(handle)
        writer.start(profile="", library="test")
        odd = writer.register_schema("vendor/Odd", "flatbuffer", b"\x00")
        ok = writer.register_schema("std_msgs/msg/String", "ros2msg", b"string data\n")
        c_odd = writer.register_channel("/odd", "flatbuffer", odd)
        c_ok = writer.register_channel("/ok", "cdr", ok)
        for i in range(3):
            writer.add_message(c_odd, 10 + i, b"\x01\x02", 0)
            writer.add_message(c_ok, 10 + i, b"\x00\x01\x00\x00\x03\x00\x00\x00hi\x00\x00", 0)
        writer.finish()
    with open_recording(path) as rec:
        msgs = list(rec.messages())
        skipped = rec.skipped
    assert [m.data.data for m in msgs] == ["hi"] * 3
    assert len(skipped) == 1
    assert skipped[0].what == "unknown message type"
    assert skipped[0].n_items == 3
    assert "/odd" in skipped[0].detail


@pytest.mark.parametrize(
    ("name", "content"),
    [
        ("notes.txt", b"just some text\n"),
        ("fake.mcap", b"not an mcap at all"),
        ("fake.bag", b"not a bag"),
        ("image.png", b"\x89PNG\r\n\x1a\n0000"),
    ],
)
def test_non_recordings_raise_one_clear_error(tmp_path: Path, name: str, content: bytes) -> None:
    path = tmp_path / name
    path.write_bytes(content)
    with pytest.raises(RecordingError, match="is not a recording") as info:
        open_recording(path)
    assert "\n" not in str(info.value)


def test_missing_path_and_plain_folder(tmp_path: Path) -> None:
    with pytest.raises(RecordingError, match="does not exist"):
        open_recording(tmp_path / "nope.mcap")
    with pytest.raises(RecordingError, match=r"without metadata\.yaml"):
        open_recording(tmp_path)
