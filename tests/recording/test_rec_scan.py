"""The damaged-file scan API (``recording.scan``) on real files cut short or with zeroed bytes."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace
from typing import TYPE_CHECKING

import pytest

from superlane_tools.recording import (
    RecordingError,
    RecordingScan,
    open_recording,
    scan_mcap,
    scan_recording,
    scan_ros1,
)

if TYPE_CHECKING:
    from mcap.records import ChunkIndex

SAMPLE = Path(__file__).resolve().parents[2] / "fixtures" / "sample_drive.mcap"
ROS1_BAG = Path("bags") / "ros1_robot_localization" / "test1.bag"


def _stored(path: Path) -> list[tuple[str, int, bytes]]:
    """Every message of an intact recording: (topic, log time, payload)."""
    with open_recording(path) as rec:
        return [(m.topic, m.log_time_ns, m.payload) for m in rec.raw_messages()]


def _assert_lost_by_topic(scan: RecordingScan, lost: list[tuple[str, int]]) -> None:
    """The scan's per-topic losses are the count and time range of ``lost`` (topic, time)."""
    expected: dict[str, list[int]] = {}
    for topic, t in lost:
        expected.setdefault(topic, []).append(t)
    assert {
        topic: (part.n_messages, part.start_ns, part.stop_ns)
        for topic, part in scan.lost_by_topic().items()
    } == {topic: (len(ts), min(ts), max(ts) + 1) for topic, ts in expected.items()}


def test_intact_mcap_scan_is_complete_and_matches_the_summary() -> None:
    scan = scan_recording(SAMPLE)
    with open_recording(SAMPLE) as rec:
        declared = {t.topic: t.message_count for t in rec.topics()}
    assert scan.format == "mcap"
    assert scan.complete
    assert scan.losses == ()
    assert scan.topic_counts() == declared
    got = sorted((m.channel.topic, m.log_time_ns, m.payload) for m in scan.messages())
    assert got == sorted(_stored(SAMPLE))


def test_cut_mcap_yields_the_messages_before_the_cut_and_names_the_lost_bytes(
    tmp_path: Path,
) -> None:
    data = SAMPLE.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: len(data) * 6 // 10])
    scan = scan_mcap(cut)
    got = [(m.channel.topic, m.log_time_ns, m.payload) for m in scan.messages()]
    assert 0 < len(got) < len(_stored(SAMPLE))
    assert set(got) <= set(_stored(SAMPLE))
    assert sum(scan.message_counts.values()) == len(got)
    assert not scan.complete
    (loss,) = scan.losses
    assert loss.what == "truncated file"
    assert loss.byte_stop == cut.stat().st_size
    assert 0 < loss.byte_start < loss.byte_stop
    assert loss.start_ns == max(t for _, t, _ in got)  # the loss came after the last read
    assert loss.n_messages is None
    assert loss.topics == ()
    assert scan.lost_by_topic() == {}
    first = next(scan.messages(["/gnss/fix"]))
    assert first.channel.schema is not None
    assert first.channel.schema.encoding == "ros2msg"
    assert first.channel.msgtype == "sensor_msgs/msg/NavSatFix"
    # the source reports the same damage
    with open_recording(cut) as rec:
        assert [(s.what, s.detail) for s in rec.skipped] == [(loss.what, loss.detail)]


def test_zeroed_mcap_chunk_is_counted_per_topic(drive: SimpleNamespace, tmp_path: Path) -> None:
    from mcap.reader import make_reader

    path = drive.write("full.mcap", "mcap", chunk_size=4096)
    with path.open("rb") as handle:
        summary = make_reader(handle).get_summary()
    assert summary is not None
    bad = sorted(summary.chunk_indexes, key=lambda ci: ci.chunk_start_offset)[2]
    data = bytearray(path.read_bytes())
    middle = bad.chunk_start_offset + bad.chunk_length // 2
    data[middle : middle + 16] = bytes(16)
    broken = tmp_path / "broken.mcap"
    broken.write_bytes(bytes(data[: -len(b"\x89MCAP0\r\n")]))  # and no closing magic
    everything = _stored(path)
    in_bad = [
        (topic, t)
        for topic, t, _ in everything
        if bad.message_start_time <= t <= bad.message_end_time
    ]
    scan = scan_recording(broken)
    kinds = [loss.what for loss in scan.losses]
    assert kinds == ["corrupt chunk", "truncated file"]
    chunk = scan.losses[0]
    assert chunk.byte_start == bad.chunk_start_offset
    assert chunk.byte_stop == bad.chunk_start_offset + bad.chunk_length
    assert chunk.n_messages == len(in_bad)
    assert (chunk.start_ns, chunk.stop_ns) == (bad.message_start_time, bad.message_end_time + 1)
    _assert_lost_by_topic(scan, in_bad)
    got = sorted((m.channel.topic, m.log_time_ns) for m in scan.messages())
    assert got == sorted({(topic, t) for topic, t, _ in everything} - set(in_bad))


def _garble_chunk_header(path: Path, dst: Path, nth: int, at: int) -> tuple[Path, ChunkIndex]:
    """Write ``path`` with 16 bytes of chunk ``nth``'s record set to 0xff from byte ``at`` of it.

    Returns the damaged copy and the chunk's index entry (the summary itself stays intact).
    """
    from mcap.reader import make_reader

    with path.open("rb") as handle:
        summary = make_reader(handle).get_summary()
    assert summary is not None
    ci = sorted(summary.chunk_indexes, key=lambda ci: ci.chunk_start_offset)[nth]
    data = bytearray(path.read_bytes())
    start = ci.chunk_start_offset + at
    data[start : start + 16] = b"\xff" * 16
    dst.write_bytes(bytes(data))
    return dst, ci


def test_garbled_chunk_header_loses_that_chunk_only(drive: SimpleNamespace, tmp_path: Path) -> None:
    """Issue 27 fuzz recover-mcap-garble: the walk reads on at the next chunk the index knows."""
    path = drive.write("full.mcap", "mcap", chunk_size=4096)
    # bytes 33..49 of the record: the CRC and the compression name's length (unreadable)
    broken, bad = _garble_chunk_header(path, tmp_path / "broken.mcap", 2, 33)
    everything = _stored(path)
    in_bad = [
        (topic, t)
        for topic, t, _ in everything
        if bad.message_start_time <= t <= bad.message_end_time
    ]
    assert 0 < len(in_bad) < len(everything) // 3
    scan = scan_mcap(broken)
    (loss,) = scan.losses  # no "truncated file": the later chunks are read
    assert loss.what == "corrupt chunk"
    assert loss.byte_start == bad.chunk_start_offset
    assert loss.n_messages == len(in_bad)
    _assert_lost_by_topic(scan, in_bad)
    got = sorted((m.channel.topic, m.log_time_ns, m.payload) for m in scan.messages())
    assert got == sorted(_stored(broken))  # what the indexed reader (slt cat) reads
    assert got == sorted(m for m in everything if (m[0], m[1]) not in set(in_bad))


def test_garbled_chunk_length_prefix_loses_nothing(drive: SimpleNamespace, tmp_path: Path) -> None:
    """The chunk's length (and start time) are garbled: the index gives the length, as the
    indexed reader reads it, and every message is read."""
    path = drive.write("full.mcap", "mcap", chunk_size=4096)
    broken, _ = _garble_chunk_header(path, tmp_path / "broken.mcap", 2, 1)
    scan = scan_mcap(broken)
    got = sorted((m.channel.topic, m.log_time_ns, m.payload) for m in scan.messages())
    assert got == sorted(_stored(path)) == sorted(_stored(broken))
    assert scan.losses == ()


@pytest.mark.realdata
def test_real_ros1_bag_cut_short(realdata: Path, tmp_path: Path) -> None:
    src = realdata / ROS1_BAG
    full = _stored(src)
    cut = tmp_path / "test1.bag"
    cut.write_bytes(src.read_bytes()[:700_000])
    scan = scan_ros1(cut)
    assert scan.format == "ros1"
    assert not scan.complete
    got = sorted((m.channel.topic, m.log_time_ns, m.payload) for m in scan.messages())
    assert 0 < len(got) < len(full)
    assert set(got) <= set(full)
    (loss,) = scan.losses
    assert loss.what == "truncated file"
    assert (loss.byte_stop, loss.start_ns) == (700_000, max(t for _, t, _ in got))
    fix = next(ch for ch in scan.channels.values() if ch.topic == "/fix")
    assert fix.schema is not None
    assert (fix.schema.name, fix.schema.encoding) == ("sensor_msgs/NavSatFix", "ros1msg")
    assert fix.msgtype == "sensor_msgs/msg/NavSatFix"
    assert fix.metadata["md5sum"]


@pytest.mark.realdata
def test_real_ros1_bag_with_a_zeroed_chunk_counts_what_each_topic_lost(
    realdata: Path, tmp_path: Path
) -> None:
    src = realdata / ROS1_BAG
    intact = scan_ros1(src)
    assert intact.complete
    assert intact.losses == ()
    full = sorted((m.channel.topic, m.log_time_ns) for m in intact.messages())
    assert len(full) == len(_stored(src))
    data = bytearray(src.read_bytes())
    middle = len(data) // 3
    data[middle : middle + 64] = bytes(64)
    zeroed = tmp_path / "zeroed.bag"
    zeroed.write_bytes(bytes(data))
    scan = scan_ros1(zeroed)
    (loss,) = scan.losses
    assert loss.what == "corrupt chunk"
    assert loss.byte_start <= middle < loss.byte_stop
    got = sorted((m.channel.topic, m.log_time_ns) for m in scan.messages())
    lost = sorted(set(full) - set(got))
    assert set(got) <= set(full)
    assert loss.n_messages == len(lost) > 0
    _assert_lost_by_topic(scan, lost)


def test_scan_of_something_else_is_one_clear_error(tmp_path: Path) -> None:
    other = tmp_path / "notes.bag"
    other.write_text("not a bag\n")
    with pytest.raises(RecordingError, match="not an MCAP file or a ROS 1 bag"):
        scan_recording(other)
    with pytest.raises(RecordingError, match="no MCAP magic"):
        scan_mcap(other)
    with pytest.raises(RecordingError, match="no ROS 1 bag magic"):
        scan_ros1(other)


def test_garbled_chunk_opcode_reads_on_by_the_index(drive: SimpleNamespace, tmp_path: Path) -> None:
    """The chunk's opcode byte garbled: the summary fails its index check, but its CRC holds, so
    the walk (scan and source alike) still reads on by the chunk index: no 'truncated file'."""
    path = drive.write("full.mcap", "mcap", chunk_size=4096)
    broken, bad = _garble_chunk_header(path, tmp_path / "broken.mcap", 2, 0)
    scan = scan_mcap(broken)
    assert [loss.what for loss in scan.losses] == ["damaged summary"]
    assert str(bad.chunk_start_offset) in scan.losses[0].detail
    got = sorted((m.channel.topic, m.log_time_ns, m.payload) for m in scan.messages())
    assert got == sorted(_stored(path)) == sorted(_stored(broken))
