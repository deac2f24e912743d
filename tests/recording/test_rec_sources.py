"""CAN-log and NMEA recordings: parsing, bad input skipped and counted, real files."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from superlane_tools.recording.canlog_source import CanLogRecording, looks_like_canlog
from superlane_tools.recording.errors import RecordingError
from superlane_tools.recording.nmea_source import NmeaRecording, looks_like_nmea, nmea_checksum_ok
from superlane_tools.recording.open import open_recording

GGA = "GNGGA,092542.00,4846.4008666,N,00854.7249096,E,4,12,0.47,419.166,M,47.535,M,0.0,0000"
RMC = "GNRMC,092542.00,A,4846.4008666,N,00854.7249096,E,0.011,,200420,,,R,V"


def _sentence(body: str) -> str:
    checksum = 0
    for char in body.encode():
        checksum ^= char
    return f"${body}*{checksum:02X}"


def test_candump_log_with_bad_lines(tmp_path: Path) -> None:
    log = tmp_path / "x.log"
    log.write_text(
        "(1000.000001) can0 123#0102030405060708\n"
        "garbage line\n"
        "(1000.000002) can0 1ABCDEF0#11\n"
        "(1000.5) can1 7FF#R\n"
        "(1000.6) can0 12G#00\n"
    )
    assert looks_like_canlog(log)
    with open_recording(log) as rec:
        msgs = list(rec.messages())
        assert [m.topic for m in msgs] == ["can0", "can0", "can1"]
        assert msgs[0].log_time_ns == 1_000_000_001_000
        assert msgs[0].data.data == bytes(range(1, 9))
        assert not msgs[0].data.is_extended
        assert msgs[1].data.id == 0x1ABCDEF0
        assert msgs[1].data.is_extended
        assert msgs[2].data.is_rtr
        assert sum(s.n_items for s in rec.skipped) == 2
        assert [t.message_count for t in rec.topics()] == [2, 1]
        assert len(list(rec.messages(topics=["can1"]))) == 1
        assert len(list(rec.messages(start_ns=1_000_000_001_500))) == 2


def test_not_a_canlog(tmp_path: Path) -> None:
    other = tmp_path / "y.log"
    other.write_text("hello\n")
    assert not looks_like_canlog(other)
    with pytest.raises(RecordingError):
        CanLogRecording(other)


def test_ford_logs_read_completely(realdata: Path) -> None:
    folder = realdata / "can_logs/ford_fusion"
    rec = CanLogRecording(folder / "lane_keep_assist_in_yellow.log")
    times = np.array([m.log_time_ns for m in rec.messages()])
    assert len(times) == 1000
    assert not rec.skipped
    lines = (folder / "car_60km.log").read_text().splitlines()
    assert len(list(CanLogRecording(folder / "car_60km.log").messages())) == len(lines)


def test_nmea_parsing_and_bad_checksums(tmp_path: Path) -> None:
    assert nmea_checksum_ok(GGA, _sentence(GGA)[-2:])
    log = tmp_path / "g.nmea"
    bad = _sentence(GGA)[:-2] + "00"
    log.write_text("\n".join([_sentence(RMC), _sentence(GGA), bad, "junk", ""]))
    assert looks_like_nmea(log)
    with open_recording(log) as rec:
        (msg,) = list(rec.messages())
        fix = msg.data
        assert fix.gga_quality == 4
        assert fix.status.status == 2
        assert fix.latitude == pytest.approx(48 + 46.4008666 / 60)
        assert fix.longitude == pytest.approx(8 + 54.7249096 / 60)
        assert fix.altitude == pytest.approx(419.166 + 47.535)
        assert msg.log_time_ns == 1587374742 * 1_000_000_000  # 2020-04-20 09:25:42 UTC
        assert sum(s.n_items for s in rec.skipped) == 2


def test_nmea_southern_western_and_no_fix(tmp_path: Path) -> None:
    gga_sw = GGA.replace(",N,", ",S,").replace(",E,4,", ",W,5,")
    gga_none = GGA.replace(",E,4,", ",E,0,").replace("092542.00", "092543.00")
    log = tmp_path / "g.log"
    log.write_text("\n".join(_sentence(s) for s in (RMC, gga_sw, gga_none)) + "\n")
    fixes = [m.data for m in NmeaRecording(log).messages()]
    assert fixes[0].latitude < 0
    assert fixes[0].longitude < 0
    assert fixes[0].gga_quality == 5
    assert fixes[1].status.status == -1
    assert np.isnan(fixes[1].latitude)


def test_real_nmea_log(realdata: Path) -> None:
    rec = NmeaRecording(realdata / "gnss/nmea.log")
    msgs = list(rec.messages())
    assert len(msgs) == 120
    assert not rec.skipped
    assert {m.data.gga_quality for m in msgs} == {4}
    assert np.all(np.diff([m.log_time_ns for m in msgs]) == 500_000_000)  # 2 Hz
