"""`slt info` rates: robust to bursts (CAN frames logged together) and exact for slow topics."""

from __future__ import annotations

import pytest

from superlane_tools.recording import open_recording, open_writer
from superlane_tools.recording.messages import can_frame, navsatfix
from superlane_tools.recording.summary import summarize

T0 = 1_700_000_000 * 10**9


def test_bursty_and_slow_topic_rates(tmp_path):
    path = tmp_path / "r.mcap"
    with open_writer(path, "mcap") as writer:
        writer.add_topic("/can", "can_msgs/msg/Frame")
        writer.add_topic("/fix", "sensor_msgs/msg/NavSatFix")
        for k in range(50 * 30):  # 30 s: two frames 1 us apart every 20 ms -> 100 frames/s
            t = T0 + k * 20_000_000
            writer.write("/can", t, can_frame(t, 0x180, b"\x00"))
            writer.write("/can", t + 1_000, can_frame(t + 1_000, 0x181, b"\x00"))
        for k in range(75):  # 2.5 Hz
            t = T0 + k * 400_000_000
            writer.write("/fix", t, navsatfix(t, "gps", 48.0, 11.0, 500.0, 0, [0.0] * 9))
    with open_recording(path) as rec:
        topics = {t.topic: t for t in summarize(rec).topics}
    assert topics["/can"].median_rate_hz == pytest.approx(100.0)
    assert topics["/fix"].median_rate_hz == pytest.approx(2.5)
