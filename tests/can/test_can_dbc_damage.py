"""Lenient DBC loading on damaged real DBCs: impossible signals, unindented duplicates."""

from __future__ import annotations

import time
from pathlib import Path

import pytest

from superlane_tools.can import load_dbc
from superlane_tools.can.errors import CanError


def _mobileye(realdata: Path) -> bytes:
    return (realdata / "dbc" / "mobileye" / "Mobileye.dbc").read_bytes()


@pytest.mark.realdata
def test_unindented_duplicate_signals_are_renamed_once(realdata: Path, tmp_path: Path) -> None:
    lines = _mobileye(realdata).splitlines(keepends=True)
    first = next(i for i, line in enumerate(lines) if line.lstrip().startswith(b"SG_ "))
    lines.insert(first + 1, lines[first])  # a duplicate signal name
    flat = [line.lstrip() if line.lstrip().startswith(b"SG_ ") else line for line in lines]
    path = tmp_path / "flat.dbc"
    path.write_bytes(b"".join(flat))
    t0 = time.perf_counter()
    loaded = load_dbc(path)
    assert time.perf_counter() - t0 < 20  # was 500 full re-parses
    renamed = [r for r in loaded.repairs if r.startswith("renamed duplicate signal")]
    assert len(renamed) == 1


@pytest.mark.realdata
@pytest.mark.parametrize("start", [b"-1", b"-63", b"9999"])
def test_signals_no_frame_can_hold_are_dropped(
    realdata: Path, tmp_path: Path, start: bytes
) -> None:
    lines = _mobileye(realdata).splitlines(keepends=True)
    k = next(i for i, line in enumerate(lines) if line.lstrip().startswith(b"SG_ "))
    name = lines[k].split()[1].decode()
    head, _, tail = lines[k].partition(b": ")
    lines[k] = head + b": " + start + tail[tail.index(b"|") :]
    path = tmp_path / "bad.dbc"
    path.write_bytes(b"".join(lines))
    loaded = load_dbc(path)
    starts = [(s.name, s.start) for m in loaded.database.messages for s in m.signals]
    assert all(0 <= start < 512 for _, start in starts)
    assert len(starts) > 10
    del name


@pytest.mark.parametrize(("start", "length"), [(-1, 8), (-20, 8), (0, 100000), (60, 65)])
def test_impossible_signal_is_dropped_with_a_note(start: int, length: int) -> None:
    from superlane_tools.can.dbc import load_dbc_text

    text = (
        'VERSION ""\nBU_: A\nBO_ 100 M: 8 A\n'
        f' SG_ S1 : {start}|{length}@1+ (1,0) [0|0] "" A\n'
        ' SG_ S2 : 0|8@1+ (1,0) [0|0] "" A\n'
    )
    loaded = load_dbc_text(text)
    assert [s.name for s in loaded.database.messages[0].signals] == ["S2"]
    assert loaded.repairs[0].startswith("dropped signal S1 of message M")


def test_unparsable_dbc_and_fifo_are_one_clear_error(tmp_path: Path) -> None:
    import os

    bad = tmp_path / "bad.dbc"
    bad.write_bytes(b'VERSION ""\nBO_ 1 M: 8 A\n SG_ S : 1099511627776|8@1+ (1,0) [0|0] "" A\n')
    with pytest.raises(CanError):
        load_dbc(bad)
    fifo = tmp_path / "fifo.dbc"
    os.mkfifo(fifo)
    with pytest.raises(CanError, match="not a regular file"):
        load_dbc(fifo)


@pytest.mark.realdata
def test_a_syntax_error_quoting_a_val_line_fails_at_once(realdata: Path, tmp_path: Path) -> None:
    """A garbled line makes cantools quote a later VAL_ line: that is no 'unused VAL_' error."""
    src = realdata / "dbc" / "opendbc" / "ford_lincoln_base_pt.dbc"
    lines = src.read_bytes().splitlines(keepends=True)
    k = max(i for i, line in enumerate(lines) if line.startswith(b"VAL_ "))
    lines[k] = lines[k].replace(b'" ;', b" ;").replace(b'";', b";")  # an unclosed quote
    path = tmp_path / "garbled.dbc"
    path.write_bytes(b"".join(lines))
    t0 = time.perf_counter()
    with pytest.raises(CanError, match="Invalid syntax"):
        load_dbc(path)
    assert time.perf_counter() - t0 < 20  # was 500 re-parses, one VAL_ line dropped each
