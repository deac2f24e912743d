"""Damaged ROS 2 sqlite3 bags: every row sqlite can still read is read, the loss is reported."""

from __future__ import annotations

import contextlib
import re
import shutil
import sqlite3
from pathlib import Path

import pytest
from typer.testing import CliRunner

from superlane_tools.cli.app import app
from superlane_tools.recording import messages as m
from superlane_tools.recording import open_recording
from superlane_tools.recording.sqlite_salvage import LOST_PAYLOAD, LOST_ROWS
from superlane_tools.recording.writers import open_writer

runner = CliRunner()
T0 = 1_700_000_000_000_000_000
PAGE = 4096
COUNTS = {"/can": 1000, "/fix": 500, "/img": 100}
Msg = tuple[str, int, bytes]


def _write_bag(path: Path, big_images: bool = False) -> Path:
    """Write a ROS 2 sqlite3 bag: CAN at 100 Hz, fixes at 50 Hz, 6 kB (or 20 kB) images."""
    size = 20_000 if big_images else 6_000
    with open_writer(path, "ros2") as w:
        w.add_topic("/fix", "sensor_msgs/msg/NavSatFix")
        w.add_topic("/can", "can_msgs/msg/Frame")
        w.add_topic("/img", "sensor_msgs/msg/CompressedImage")
        for i in range(1000):
            t = T0 + i * 10_000_000
            w.write("/can", t, m.can_frame(t, 0x100, bytes([i % 256] * 8)))
            if i % 2 == 0:
                w.write("/fix", t + 1, m.navsatfix(t, "gps", 48 + i * 1e-6, 11.0, 500.0, 2))
            if i % 10 == 0:
                w.write(
                    "/img", t + 2, m.compressed_image(t, "cam", "jpeg", bytes([i % 251]) * size)
                )
    return path


def _read(path: Path) -> tuple[list[Msg], list[tuple[str, str, int]]]:
    with open_recording(path) as rec:
        got = [(r.topic, r.log_time_ns, r.payload) for r in rec.raw_messages()]
        return got, [(s.what, s.detail, s.n_items) for s in rec.skipped]


def _damaged(src: Path, dst: Path, edit: bytes | tuple[int, int]) -> Path:
    """Copy a bag folder; replace its .db3 with ``edit`` (bytes) or zero ``(first, n)`` pages."""
    shutil.copytree(src, dst)
    (db3,) = dst.glob("*.db3")
    if isinstance(edit, bytes):
        db3.write_bytes(edit)
    else:
        first, n = edit
        data = bytearray(db3.read_bytes())
        data[(first - 1) * PAGE : (first - 1 + n) * PAGE] = bytes(n * PAGE)
        db3.write_bytes(bytes(data))
    return dst


def _pages(db3: Path, table: str, kind: str) -> list[int]:
    """Return the page numbers of ``table`` of one kind (``leaf``, ``overflow``, ``internal``)."""
    import apsw

    flags = apsw.SQLITE_OPEN_READONLY | apsw.SQLITE_OPEN_URI
    db = apsw.Connection(f"file:{db3}?immutable=1", flags=flags)
    rows = db.execute("SELECT pageno FROM dbstat WHERE name = ? AND pagetype = ?", (table, kind))
    return sorted(int(row[0]) for row in rows)


@pytest.fixture(scope="module")
def bag(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, list[Msg]]:
    """The intact bag and every message it holds."""
    path = _write_bag(tmp_path_factory.mktemp("salvage") / "good")
    got, skipped = _read(path)
    assert skipped == []
    assert len(got) == sum(COUNTS.values())
    return path, got


def _lost_counts(detail: str) -> dict[str, int]:
    return {t: int(n) for t, n in re.findall(r"(/\w+): (\d+) of \d+ lost", detail)}


@pytest.mark.parametrize("fraction", [0.5, 0.9])
def test_cut_bag_keeps_every_row_before_the_cut(
    bag: tuple[Path, list[Msg]], tmp_path: Path, fraction: float
) -> None:
    good, expected = bag
    (db3,) = good.glob("*.db3")
    data = db3.read_bytes()
    cut = _damaged(good, tmp_path / "cut", data[: int(len(data) * fraction)])
    got, skipped = _read(cut)
    assert got == [msg for msg in expected if msg in got]  # in order, nothing invented
    assert got[:-20] == expected[: len(got) - 20]  # the rows before the cut
    assert len(got) > (fraction - 0.12) * len(expected)
    rows = [s for s in skipped if s[0] == LOST_ROWS]
    assert len(rows) == 1
    _, detail, n_lost = rows[0]
    payload_lost = sum(s[2] for s in skipped if s[0] == LOST_PAYLOAD)
    assert len(got) + n_lost + payload_lost == len(expected)
    lost = _lost_counts(detail)
    for topic, declared in COUNTS.items():
        kept = sum(1 for g in got if g[0] == topic)
        assert lost[topic] == declared - kept - (1 if payload_lost and topic == "/img" else 0)
    assert "and the end" in detail


def test_zeroed_leaf_page_loses_only_its_rows(bag: tuple[Path, list[Msg]], tmp_path: Path) -> None:
    good, expected = bag
    (db3,) = good.glob("*.db3")
    leaves = _pages(db3, "messages", "leaf")
    damaged = _damaged(good, tmp_path / "zeroed", (leaves[len(leaves) // 2], 1))
    got, skipped = _read(damaged)
    (row,) = [s for s in skipped if s[0] == LOST_ROWS]
    assert 0 < row[2] < 40  # one leaf page of rows
    assert len(got) + row[2] == len(expected)
    missing = [i for i, msg in enumerate(expected) if msg not in got]
    assert got == [msg for msg in expected if msg in got]
    assert len(missing) == row[2]
    assert sum(_lost_counts(row[1]).values()) == row[2]
    assert re.search(r"rows \d+\.\.\d+ unreadable", row[1])


def test_damaged_table_root_reports_everything_lost(
    bag: tuple[Path, list[Msg]], tmp_path: Path
) -> None:
    good, expected = bag
    (db3,) = good.glob("*.db3")
    (root,) = _pages(db3, "messages", "internal")
    got, skipped = _read(_damaged(good, tmp_path / "root", (root, 1)))
    assert got == []
    assert skipped == [(LOST_ROWS, skipped[0][1], len(expected))]


def test_zeroed_index_page_loses_nothing(bag: tuple[Path, list[Msg]], tmp_path: Path) -> None:
    good, expected = bag
    (db3,) = good.glob("*.db3")
    index = _pages(db3, "timestamp_idx", "leaf")
    got, skipped = _read(_damaged(good, tmp_path / "index", (index[len(index) // 2], 1)))
    assert got == expected
    assert skipped == []


def test_damage_met_while_reading_continues_row_by_row(tmp_path: Path) -> None:
    """rosbags opens the file, then fails inside an image's overflow chain: the rest is read."""
    good = _write_bag(tmp_path / "good", big_images=True)
    expected, _ = _read(good)
    (db3,) = good.glob("*.db3")
    overflow = _pages(db3, "messages", "overflow")
    page = overflow[len(overflow) // 2]
    got, skipped = _read(_damaged(good, tmp_path / "chain", (page, 1)))
    missing = [msg for msg in expected if msg not in got]
    assert [msg[0] for msg in missing] == ["/img"]
    assert got == [msg for msg in expected if msg in got]
    assert [s[0] for s in skipped] == [LOST_PAYLOAD]


def test_uncheckpointed_wal_is_read_without_writing_beside_it(
    bag: tuple[Path, list[Msg]], tmp_path: Path
) -> None:
    """A recorder that died leaves rows in ``-wal``: they are read, from a private copy."""
    good, expected = bag
    src = tmp_path / "live"
    shutil.copytree(good, src)
    (db3,) = src.glob("*.db3")
    with contextlib.closing(sqlite3.connect(db3)) as db:
        db.execute("PRAGMA journal_mode = WAL")
        db.execute("PRAGMA wal_autocheckpoint = 0")
        db.execute(
            "INSERT INTO messages (topic_id, timestamp, data) SELECT topic_id,"
            " timestamp + 10000000000, data FROM messages WHERE id = 1"
        )
        db.commit()
        crashed = tmp_path / "crashed"
        crashed.mkdir()
        for path in src.iterdir():  # copied while the writer still holds the log
            if not path.name.endswith("-shm"):
                shutil.copyfile(path, crashed / path.name)
    before = sorted((p.name, p.read_bytes()) for p in crashed.iterdir())
    assert (crashed / f"{db3.name}-wal").stat().st_size > 0
    got, skipped = _read(crashed)
    assert skipped == []
    assert got[:-1] == expected
    assert got[-1] == (expected[0][0], expected[0][1] + 10_000_000_000, expected[0][2])
    assert sorted((p.name, p.read_bytes()) for p in crashed.iterdir()) == before


@pytest.mark.parametrize("command", ["info", "cat", "extract", "filter"])
def test_cli_reports_one_line_and_exit_3(
    bag: tuple[Path, list[Msg]], tmp_path: Path, command: str
) -> None:
    good, _ = bag
    (db3,) = good.glob("*.db3")
    data = db3.read_bytes()
    cut = _damaged(good, tmp_path / "cut", data[: len(data) // 2])
    args = [command, str(cut)]
    if command in {"extract", "filter"}:
        args += ["-o", str(tmp_path / "out")]
    before = sorted((p.name, p.read_bytes()) for p in cut.iterdir())
    result = runner.invoke(app, args)
    assert result.exit_code == 3, result.output
    assert sorted((p.name, p.read_bytes()) for p in cut.iterdir()) == before  # read-only
    lines = [x for x in result.output.splitlines() if x.startswith("slt: skipped: unreadable")]
    assert len(lines) == 1, result.output
    assert "of 1000 lost" in lines[0]
    if command == "filter":
        filtered, skipped = _read(tmp_path / "out")
        damaged, _ = _read(cut)
        assert skipped == []
        assert filtered == damaged


@pytest.mark.realdata
def test_rosbag2_split_fixture_with_one_file_cut(realdata: Path, tmp_path: Path) -> None:
    """rosbag2's own split sqlite3 bag: the cut file loses its tail, the other files nothing."""
    src = realdata / "bags" / "ros2_format_fixtures" / "sqlite3" / "wbag"
    expected, _ = _read(src)
    bag_copy = tmp_path / "wbag"
    shutil.copytree(src, bag_copy)
    for path in bag_copy.rglob("*"):
        path.chmod(0o644)
    cut_file = bag_copy / "wbag_2.db3"
    data = cut_file.read_bytes()
    cut_file.write_bytes(data[: len(data) // 2])
    got, skipped = _read(bag_copy)
    (row,) = [s for s in skipped if s[0] == LOST_ROWS]
    assert row[1].startswith("wbag_2.db3: rows ")
    assert (
        0 < len(expected) - len(got) == row[2] + sum(s[2] for s in skipped if s[0] == LOST_PAYLOAD)
    )
    assert set(got) <= set(expected)
