"""The GNSS sink keeps tens of bytes per fix, not a row of Python objects."""

from __future__ import annotations

import tracemalloc
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest

from superlane_tools.recording import open_recording
from superlane_tools.recording.messages import navsatfix
from superlane_tools.recording.writers import open_writer
from superlane_tools.records import Message
from superlane_tools.reporting import Provenance
from superlane_tools.reporting.gnss_sink import RTK_SCHEMA, RtkSink

T0 = 1_700_000_000_000_000_000
N = 20_000  # about 17 minutes at 20 Hz


def _write_fixes(path: Path, varying_covariance: bool) -> Path:
    """Write ``N`` 20 Hz NavSatFix messages on two topics (RTK fixed, a few with no fix)."""
    with open_writer(path, "mcap") as w:
        w.add_topic("/gnss/fix", "sensor_msgs/msg/NavSatFix")
        w.add_topic("/gnss2/fix", "sensor_msgs/msg/NavSatFix")
        for i in range(N):
            t = T0 + i * 50_000_000
            var = 1e-4 * (1 + i % 7) if varying_covariance else 1e-4
            cov = None if i % 1000 == 5 else np.diag([var, var, 4 * var])
            topic = "/gnss2/fix" if i % 10 == 0 else "/gnss/fix"
            status = -1 if i % 500 == 3 else 2
            fix = navsatfix(t, "gps", 48.0 + i * 1e-6, 11.0 + i * 2e-6, 500.0, status, cov)
            w.write(topic, t, fix)
    return path


def _messages(path: Path) -> list[Message]:
    with open_recording(path) as rec:
        return list(rec.messages())


@pytest.mark.parametrize(("varying", "bound"), [(False, 80), (True, 160)])
def test_sink_holds_tens_of_bytes_per_fix(tmp_path: Path, varying: bool, bound: int) -> None:
    messages = _messages(_write_fixes(tmp_path / "fixes.mcap", varying))
    assert len(messages) == N
    sink = RtkSink(tmp_path / "rtk.parquet", None, Provenance(command="test"))
    tracemalloc.start()  # numpy reports its buffers to tracemalloc
    try:
        before = tracemalloc.get_traced_memory()[0]
        for msg in messages:
            sink.add(msg)
        per_fix = (tracemalloc.get_traced_memory()[0] - before) / N
    finally:
        tracemalloc.stop()
    assert per_fix < bound, f"{per_fix:.0f} bytes per fix held (a Python row took ~1500)"
    assert len(sink) == N
    (written,) = sink.close(ok=True)
    table = pq.read_table(written)
    assert table.schema.remove_metadata().equals(RTK_SCHEMA)
    assert b"superlane_tools" in (table.schema.metadata or {})
    rows = table.to_pandas()
    assert rows["log_time_ns"].is_monotonic_increasing
    assert (rows["topic"] == "/gnss2/fix").sum() == N // 10
    assert (rows["covariance_type"] == 0).sum() == N // 1000  # unknown: zeros, type 0
    i = 1234
    assert rows["covariance_m2"][i][0] == pytest.approx(1e-4 * (1 + i % 7) if varying else 1e-4)
    assert rows["latitude_deg"][i] == 48.0 + i * 1e-6
    assert rows["fix_status"][3] == -1
    assert np.isnan(rows["east_m"][3])  # no fix: no position, whatever the numbers say
    assert rows["east_m"][0] == 0.0
    assert rows["stamp_ns"][i] == T0 + i * 50_000_000
