"""The one streaming pass: messages routed by topic, sinks closed in order, failures discard."""

from __future__ import annotations

from pathlib import Path

import pyarrow.parquet as pq
import pytest

from superlane_tools.recording import open_recording
from superlane_tools.records import Message
from superlane_tools.reporting import Provenance
from superlane_tools.reporting.camera_info_sink import CameraInfoSink
from superlane_tools.reporting.can_sink import CanSink
from superlane_tools.reporting.gnss_sink import RtkSink
from superlane_tools.reporting.message_pass import stream_messages

SAMPLE = Path(__file__).resolve().parents[2] / "fixtures" / "sample_drive.mcap"
INFO, GNSS, CAN = "/camera/camera_info", "/gnss/fix", "/can/rx"


def test_each_topic_goes_to_its_sink_and_sinks_close_in_order(tmp_path: Path) -> None:
    provenance = Provenance(command="test")
    rtk = RtkSink(tmp_path / "rtk.parquet", None, provenance)
    info = CameraInfoSink(tmp_path / "camera_info.parquet", provenance)
    ticks: list[int] = []
    with open_recording(SAMPLE) as rec:
        messages = list(rec.messages(topics=[INFO, GNSS, CAN]))
    read = stream_messages(messages, {GNSS: rtk, INFO: info}, [rtk, info], ticks.append, 100)
    assert read.files == ((tmp_path / "rtk.parquet",), (tmp_path / "camera_info.parquet",))
    assert read.messages == len(messages)  # the CAN frames are read, taken by no one
    times = [m.log_time_ns for m in messages]
    assert read.span_ns == (min(times), max(times))
    assert ticks == list(range(100, len(messages) + 1, 100))
    fixes = sum(m.topic == GNSS for m in messages)
    assert len(rtk) == fixes
    assert pq.read_metadata(tmp_path / "rtk.parquet").num_rows == fixes
    assert pq.read_metadata(tmp_path / "camera_info.parquet").num_rows == 1  # one calibration


class _Interrupted:
    """Passes CAN frames on to a sink and stops the pass at the ``n``-th, as Ctrl-C would."""

    def __init__(self, sink: CanSink, n: int) -> None:
        self.sink, self.n = sink, n

    def add(self, msg: Message) -> None:
        self.sink.add(msg)
        self.n -= 1
        if self.n == 0:
            raise KeyboardInterrupt


def test_a_failed_pass_discards_every_output(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr("superlane_tools.reporting.can_sink.CHUNK_ROWS", 100)  # row groups early
    provenance = Provenance(command="test")
    can = CanSink(tmp_path / "can_raw.parquet", tmp_path / "can_signals.parquet", {}, provenance)
    rtk = RtkSink(tmp_path / "rtk.parquet", None, provenance)
    with open_recording(SAMPLE) as rec:
        messages = list(rec.messages(topics=[GNSS, CAN]))
    with pytest.raises(KeyboardInterrupt):
        stream_messages(messages, {GNSS: rtk, CAN: _Interrupted(can, 500)}, [can, rtk])
    assert can.frames == 500  # five row groups were written before the interrupt
    assert list(tmp_path.iterdir()) == []  # and discarded: no table, no temp file


def test_an_empty_pass_still_writes_what_a_sink_always_writes(tmp_path: Path) -> None:
    can = CanSink(tmp_path / "c.parquet", tmp_path / "s.parquet", {}, Provenance(command="t"))
    read = stream_messages([], {}, [can])
    assert (read.messages, read.span_ns) == (0, None)
    assert read.files == ((tmp_path / "c.parquet",),)  # no frame: still the empty table
