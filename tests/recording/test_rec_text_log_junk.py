"""Binary junk in text logs (NMEA, candump, ASC, CSV in convert): every good record is kept,
every damaged one is counted on one ``slt: skipped:`` line, and the exit code is 3.

The logs are real (u-blox NMEA, a Ford Fusion candump, comma2k19 CAN speed), copied and damaged
the ways a flaky SD card or a cut serial line damages them: a NUL where a line break was, a NUL
run over the end of one sentence and the start of the next, random bytes inserted.
"""

from __future__ import annotations

import random
import re
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from superlane_tools.cli.app import app
from superlane_tools.recording import open_recording

pytestmark = pytest.mark.realdata
runner = CliRunner()
JUNK = bytes(random.Random(27).randrange(256) for _ in range(64))


def _nul_for_newline(data: bytes, at: int) -> bytes:
    i = data.index(b"\n", at)
    return data[:i] + b"\x00" + data[i + 1 :]


def _nul_run_over_boundary(data: bytes, at: int) -> bytes:
    i = data.index(b"\n", at)
    return data[: i - 1] + b"\x00" * 4 + data[i + 3 :]


def _junk_inserted(data: bytes, at: int) -> bytes:
    return data[:at] + JUNK + data[at:]


DAMAGE: dict[str, Callable[[bytes, int], bytes]] = {
    "nul-for-newline": _nul_for_newline,
    "nul-run": _nul_run_over_boundary,
    "junk": _junk_inserted,
}


def _intact_lines(clean: bytes, damaged: bytes) -> list[bytes]:
    """Return the lines of ``clean`` that are still whole lines of ``damaged``.

    Independent of the readers, and a lower bound: a record that now follows junk on the same
    line (its line break lost) is not counted here, though the readers may still read it.
    """
    whole = set(damaged.splitlines())
    return [line for line in clean.splitlines() if line in whole]


def _skipped_lines(output: str) -> list[str]:
    return [ln for ln in output.splitlines() if ln.startswith("slt: skipped:")]


def _count(line: str) -> int:
    match = re.search(r"\((\d+)\)", line)
    assert match, line
    return int(match[1])


@pytest.mark.parametrize("damage", DAMAGE)
@pytest.mark.parametrize("at", [10, 3000])
def test_nmea_junk_is_counted_and_good_fixes_kept(
    realdata: Path, tmp_path: Path, damage: str, at: int
) -> None:
    clean = (realdata / "gnss" / "nmea.log").read_bytes()
    damaged = DAMAGE[damage](clean, at)
    log = tmp_path / "nmea.log"
    log.write_bytes(damaged)
    gga = [ln for ln in _intact_lines(clean, damaged) if b"GGA," in ln]
    with open_recording(log) as rec:
        got = list(rec.raw_messages())
        skipped = rec.skipped
    sentences = [m.payload for m in got]
    # every intact GGA sentence gives its fix (a GGA run into junk after its checksum too)
    assert set(gga) <= set(sentences)
    lost = sum(1 for ln in clean.splitlines() if b"GGA," in ln) - len(got)
    assert skipped, "damage not reported"
    assert sum(s.n_items for s in skipped) >= max(1, lost)
    out = tmp_path / "out"
    res = runner.invoke(app, ["extract", str(log), "--out", str(out)], catch_exceptions=False)
    assert res.exit_code == 3, res.output
    (line,) = _skipped_lines(res.output)
    assert line.startswith("slt: skipped: bad NMEA")


def test_nmea_sentences_run_together_are_both_read(realdata: Path, tmp_path: Path) -> None:
    clean = (realdata / "gnss" / "nmea.log").read_bytes()
    lines = clean.splitlines(keepends=True)
    k = next(i for i, ln in enumerate(lines) if ln.startswith(b"$GNRMC")) + 2
    # the RMC's line break (and the next "$G") overwritten by NULs: the GGA is damaged and lost,
    # the RMC before it is whole; a NUL for the line break alone loses nothing
    merged = b"".join(lines[:k]) + lines[k].rstrip(b"\r\n") + b"\x00" + b"".join(lines[k + 1 :])
    log = tmp_path / "merged.log"
    log.write_bytes(merged)
    with open_recording(log) as rec:
        n = len(list(rec.messages()))
        skipped = rec.skipped
    with open_recording(realdata / "gnss" / "nmea.log") as rec:
        assert n == len(list(rec.messages()))
    assert [(s.what, s.n_items) for s in skipped] == [("bad NMEA line", 1)]


@pytest.mark.parametrize("damage", DAMAGE)
def test_candump_junk_is_counted_and_good_frames_kept(
    realdata: Path, tmp_path: Path, damage: str
) -> None:
    clean = (realdata / "can_logs" / "ford_fusion" / "car_50km.log").read_bytes()
    damaged = DAMAGE[damage](clean, 3000)
    log = tmp_path / "bus.log"
    log.write_bytes(damaged)
    intact = _intact_lines(clean, damaged)
    with open_recording(log) as rec:
        frames = list(rec.messages())
        skipped = rec.skipped
    total = len(clean.splitlines())
    assert len(frames) >= len(intact)
    assert len(frames) < total
    assert sum(s.n_items for s in skipped) >= 1
    # what is lost is counted: every frame is read or inside a counted damaged piece
    assert len(frames) + 2 * sum(s.n_items for s in skipped) >= total
    res = runner.invoke(app, ["extract", str(log), "--out", str(tmp_path / "o")])
    assert res.exit_code == 3, res.output
    (line,) = _skipped_lines(res.output)
    assert line.startswith("slt: skipped: bad CAN log line")


def test_candump_frames_run_together_are_each_read(realdata: Path, tmp_path: Path) -> None:
    clean = (realdata / "can_logs" / "ford_fusion" / "car_50km.log").read_bytes()
    log = tmp_path / "bus.log"
    log.write_bytes(_nul_for_newline(clean, 3000))
    with open_recording(log) as rec:
        n = len(list(rec.messages()))
        skipped = [(s.what, s.n_items) for s in rec.skipped]
    # the frame before the NUL is damaged (junk after its payload), the one after it is whole
    assert n == len(clean.splitlines()) - 1
    assert skipped == [("bad CAN log line", 1)]


@pytest.fixture(scope="module")
def real_asc(realdata: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The real candump log written as Vector ASC by python-can."""
    import can

    asc = tmp_path_factory.mktemp("asc") / "clean.asc"
    writer = can.ASCWriter(str(asc))
    for msg in can.CanutilsLogReader(str(realdata / "can_logs/ford_fusion/car_50km.log")):
        writer.on_message_received(msg)
    writer.stop()
    return asc


@pytest.mark.parametrize("damage", DAMAGE)
def test_asc_junk_is_counted(real_asc: Path, tmp_path: Path, damage: str) -> None:
    asc = real_asc
    clean = asc.read_bytes()
    log = tmp_path / "bus.asc"
    log.write_bytes(DAMAGE[damage](clean, 3000))
    with open_recording(asc) as rec:
        total = len(list(rec.messages()))
    with open_recording(log) as rec:
        n = len(list(rec.messages()))
        skipped = sum(s.n_items for s in rec.skipped)
    assert 0 < total - n <= 2 * skipped
    res = runner.invoke(app, ["extract", str(log), "--out", str(tmp_path / "o")])
    assert res.exit_code == 3, res.output
    assert len(_skipped_lines(res.output)) == 1


def _convert_damaged(src: Path, data: bytes) -> tuple[str, int]:
    """Write ``data`` to ``src``, ``slt convert`` it (exit 3): its one skipped line, messages."""
    src.write_bytes(data)
    out = src.with_suffix(".mcap")
    res = runner.invoke(app, ["convert", str(src), "-o", str(out)])
    assert res.exit_code == 3, res.output
    (line,) = _skipped_lines(res.output)
    with open_recording(out) as rec:
        return line, sum(1 for _ in rec.raw_messages())


def _speed_csv(realdata: Path) -> bytes:
    folder = realdata / "comma2k19" / "segment" / "processed_log" / "CAN" / "speed"
    t = np.load(folder / "t")
    v = np.load(folder / "value").reshape(len(t), -1)[:, 0]
    rows = ["t_s,speed_mps", *(f"{a:.6f},{b:.4f}" for a, b in zip(t, v, strict=True))]
    return ("\n".join(rows) + "\n").encode()


@pytest.mark.parametrize(
    ("damage", "lost", "kind"),
    [
        ("nul-for-newline", 2, "bad CSV line"),  # two rows run together: one 3-field line
        ("nul-in-value", 1, "bad CSV value"),
        ("junk-time", 1, "bad CSV time"),
    ],
)
def test_csv_convert_junk_is_counted(
    realdata: Path, tmp_path: Path, damage: str, lost: int, kind: str
) -> None:
    clean = _speed_csv(realdata)
    rows = clean.splitlines(keepends=True)
    if damage == "nul-for-newline":
        data = _nul_for_newline(clean, 3000)
    elif damage == "nul-in-value":
        rows[100] = rows[100].split(b",")[0] + b",1\x003\n"
        data = b"".join(rows)
    else:
        rows[100] = b"\xff\xfe\x00junk," + rows[100].split(b",")[1]
        data = b"".join(rows)
    line, got = _convert_damaged(tmp_path / "speed.csv", data)
    assert line.startswith(f"slt: skipped: {kind} (1)")
    assert got == len(rows) - 1 - lost


@pytest.fixture(scope="module")
def real_gpx(realdata: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The real NMEA log's 120 fixes written as a GPX track by gpxpy."""
    import datetime

    import gpxpy.gpx

    gpx = gpxpy.gpx.GPX()
    track = gpxpy.gpx.GPXTrack()
    segment = gpxpy.gpx.GPXTrackSegment()
    gpx.tracks.append(track)
    track.segments.append(segment)
    with open_recording(realdata / "gnss" / "nmea.log") as rec:
        for m in rec.messages():
            when = datetime.datetime.fromtimestamp(m.log_time_ns / 1e9, datetime.UTC)
            segment.points.append(
                gpxpy.gpx.GPXTrackPoint(m.data.latitude, m.data.longitude, time=when)
            )
    path = tmp_path_factory.mktemp("gpx") / "track.gpx"
    path.write_text(gpx.to_xml())
    return path


@pytest.mark.parametrize("damage", ["nul-run", "junk", "cut"])
def test_gpx_convert_junk_is_counted(real_gpx: Path, tmp_path: Path, damage: str) -> None:
    clean = real_gpx.read_bytes()
    total = clean.count(b"<trkpt ")
    at = clean.index(b"<trkpt ", len(clean) // 3) + 20  # inside one point's element
    if damage == "nul-run":
        data = clean[:at] + b"\x00" * 4 + clean[at + 4 :]
    elif damage == "junk":
        data = clean[:at] + JUNK + clean[at:]
    else:
        data = clean[:at]
    line, got = _convert_damaged(tmp_path / "track.gpx", data)
    assert line.startswith("slt: skipped: bad GPX point (1): track.gpx:")
    # every point before and after the damaged one is kept (a cut file ends at it)
    assert got == (total - 1 if damage != "cut" else clean[:at].count(b"<trkpt ") - 1)
