"""Damage classes of every reader: each recovers what is intact and reports what is lost."""

from __future__ import annotations

import random
from pathlib import Path
from types import SimpleNamespace

import pytest

from superlane_tools.recording import RecordingError, open_recording


def _read(path: Path) -> tuple[list[tuple[str, int]], list[str]]:
    with open_recording(path) as rec:
        got = [(m.topic, m.log_time_ns) for m in rec.messages()]
        return got, [s.what for s in rec.skipped]


def _summary_start(path: Path) -> int:
    import struct

    data = path.read_bytes()
    footer = data[-8 - 29 :]
    return int(struct.unpack_from("<Q", footer, 9)[0])


def test_mcap_damaged_summary_falls_back_to_scanning(
    drive: SimpleNamespace, tmp_path: Path
) -> None:
    path = drive.write("full.mcap", "mcap", chunk_size=4096)
    expected, _ = _read(path)
    data = path.read_bytes()
    start = _summary_start(path)
    assert 0 < start < len(data)
    flipped = tmp_path / "flipped.mcap"
    positions = range(start, len(data) - 8, 11)
    assert len(positions) > 40
    for pos in positions:
        damaged = bytearray(data)
        damaged[pos] ^= 0x5A
        flipped.write_bytes(bytes(damaged))
        got, skipped = _read(flipped)
        assert got == expected, f"flip at byte {pos}: {len(got)} of {len(expected)} messages"
        assert skipped, f"flip at byte {pos} is not reported"


def test_mcap_log_times_beyond_int64_are_reported(tmp_path: Path) -> None:
    from mcap.writer import Writer

    path = tmp_path / "late.mcap"
    with path.open("wb") as handle:
        writer = Writer(handle)
        writer.start()
        schema = writer.register_schema("x", "jsonschema", b"{}")
        channel = writer.register_channel("/late", "json", schema)
        for t in (1, 2, 2**63, 2**64 - 1):
            writer.add_message(channel, log_time=t, data=b"{}", publish_time=t)
        writer.finish()
    got, skipped = _read(path)
    assert got == [("/late", 1), ("/late", 2)]
    assert skipped == ["log time beyond int64 ns (after year 2262)"]


def _blf(tmp_path: Path, realdata: Path, n: int = 3000) -> tuple[Path, int]:
    import can

    src = realdata / "can_logs" / "ford_fusion" / "car_50km.log"
    with can.CanutilsLogReader(src) as reader:
        msgs = [m for _, m in zip(range(n), reader, strict=False)]
    path = tmp_path / "drive.blf"
    with can.Logger(path) as log:
        for msg in msgs:
            log.on_message_received(msg)
    return path, len(msgs)


@pytest.mark.realdata
def test_blf_garbled_bytes_keep_the_other_frames(realdata: Path, tmp_path: Path) -> None:
    path, total = _blf(tmp_path, realdata)
    data = path.read_bytes()
    rng = random.Random(7)
    damaged = tmp_path / "garbled.blf"
    for pos in (200, 3000, len(data) // 2, len(data) - 2000):
        buf = bytearray(data)
        buf[pos : pos + 16] = bytes(rng.randrange(256) for _ in range(16))
        damaged.write_bytes(bytes(buf))
        got, skipped = _read(damaged)
        assert 0 < len(got) <= total + 64, pos
        assert skipped, pos


@pytest.mark.realdata
def test_truncated_blf_keeps_the_frames_before_the_cut(realdata: Path, tmp_path: Path) -> None:
    path, total = _blf(tmp_path, realdata)
    data = path.read_bytes()
    full, _ = _read(path)
    assert len(full) == total
    cut = tmp_path / "cut.blf"
    previous = 0
    for frac in (0.3, 0.5, 0.7, 0.95):
        cut.write_bytes(data[: int(len(data) * frac)])
        got, skipped = _read(cut)
        assert got == full[: len(got)]
        assert len(got) > previous  # the intact prefix of the cut container is recovered
        previous = len(got)
        assert "truncated file" in skipped


@pytest.mark.realdata
def test_asc_with_a_non_utf8_header_byte(realdata: Path, tmp_path: Path) -> None:
    import can

    src = realdata / "can_logs" / "ford_fusion" / "car_50km.log"
    path = tmp_path / "drive.asc"
    with can.Logger(path) as log, can.CanutilsLogReader(src) as reader:
        for _, msg in zip(range(500), reader, strict=False):
            log.on_message_received(msg)
    data = bytearray(path.read_bytes())
    data[5] = 0xE9
    path.write_bytes(bytes(data))
    got, skipped = _read(path)
    assert len(got) == 500
    assert skipped == ["bad CAN log line"]


@pytest.mark.realdata
@pytest.mark.parametrize(
    "head",
    [b"# candump of the test drive\n", b"\x00\x01garbage\xff\xfe\n", b"(12.5) can0 12#zz\n"],
    ids=["comment", "binary", "malformed"],
)
def test_candump_with_a_bad_first_line(realdata: Path, tmp_path: Path, head: bytes) -> None:
    src = realdata / "can_logs" / "ford_fusion" / "car_50km.log"
    full, _ = _read(src)
    path = tmp_path / "drive.log"
    path.write_bytes(head + src.read_bytes())
    got, _ = _read(path)
    assert got == full


@pytest.mark.realdata
@pytest.mark.parametrize(
    "head",
    [b"# nmea log\n", b"\x00\x00\x00\n", b"$GPGGA,garbage*00\n"],
    ids=["comment", "nul", "malformed"],
)
def test_nmea_with_a_bad_first_line(realdata: Path, tmp_path: Path, head: bytes) -> None:
    src = realdata / "gnss" / "nmea.log"
    full, _ = _read(src)
    path = tmp_path / "fixes.log"
    path.write_bytes(head + src.read_bytes())
    got, _ = _read(path)
    assert got == full


@pytest.mark.realdata
def test_candump_extreme_lines_are_skipped(realdata: Path, tmp_path: Path) -> None:
    src = realdata / "can_logs" / "ford_fusion" / "car_50km.log"
    full, _ = _read(src)
    lines = src.read_bytes().splitlines(keepends=True)
    path = tmp_path / "odd.log"
    huge = b"(1.0) can0 123#" + b"AB" * 250_000 + b"\n"
    late = b"(100000000000000000000.0) can0 123#00\n"
    path.write_bytes(b"".join([lines[0], huge, *lines[1:], late]))
    got, skipped = _read(path)
    assert got == full
    assert "bad CAN log line" in skipped


def test_truncated_or_flipped_ros1_bag_keeps_what_came_before(
    drive: SimpleNamespace, tmp_path: Path
) -> None:
    path = drive.write("drive.bag", "ros1")
    expected, _ = _read(path)
    data = path.read_bytes()
    damaged = tmp_path / "damaged.bag"
    rng = random.Random(3)
    for pos in sorted(rng.sample(range(4096, len(data) - 4096), 25)):
        buf = bytearray(data)
        buf[pos] ^= 0xFF
        damaged.write_bytes(bytes(buf))
        try:
            got, skipped = _read(damaged)
        except RecordingError:
            continue  # an index damaged so that the bag cannot be opened: one clear error
        assert set(got) <= set(expected) or skipped, pos


@pytest.mark.parametrize("frac", [0.3, 0.5, 0.7, 0.95])
def test_truncated_ros1_bag_is_recovered_like_reindex(
    drive: SimpleNamespace, tmp_path: Path, frac: float
) -> None:
    path = drive.write("drive.bag", "ros1")
    expected, _ = _read(path)
    data = path.read_bytes()
    active = tmp_path / "crashed.bag.active"  # what a recorder that crashed leaves
    active.write_bytes(data[: int(len(data) * frac)])
    got, skipped = _read(active)
    assert got == expected[: len(got)]
    assert len(got) >= len(expected) * (frac - 0.15)  # the chunk holds 8-88 % of the file
    assert "unindexed bag" in skipped


@pytest.mark.realdata
def test_real_ros1_bag_cut_in_half(realdata: Path, tmp_path: Path) -> None:
    src = realdata / "bags" / "ros1_robot_localization" / "test1.bag"
    with open_recording(src) as rec:
        full = [(m.topic, m.log_time_ns) for m in rec.raw_messages(["/fix"])]
    cut = tmp_path / "test1.bag"
    cut.write_bytes(src.read_bytes()[: src.stat().st_size // 2])
    with open_recording(cut) as rec:
        got = [(m.topic, m.log_time_ns) for m in rec.raw_messages(["/fix"])]
    assert 0 < len(got) < len(full)
    assert got == full[: len(got)]


def test_ros2_messages_with_an_unknown_topic_id_are_reported(
    drive: SimpleNamespace, tmp_path: Path
) -> None:
    import sqlite3

    folder = drive.write("bag2", "ros2")
    db3 = next(folder.glob("*.db3"))
    with sqlite3.connect(db3) as db:
        db.execute(
            "UPDATE messages SET topic_id = 999 WHERE id IN (SELECT id FROM messages LIMIT 4)"
        )
    with open_recording(folder) as rec:
        list(rec.messages())
        skipped = rec.skipped
    assert [(s.what, s.n_items) for s in skipped] == [("message with an unknown topic id", 4)]
