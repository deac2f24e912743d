"""`slt info` from an MCAP's summary section, file facts, CAN ids, and rate memory."""

from __future__ import annotations

import json
import tracemalloc
from pathlib import Path

import pytest
from typer.testing import CliRunner

from superlane_tools.cli.app import app
from superlane_tools.recording import messages as m
from superlane_tools.recording.summary import _TopicStats, median_with_zeros
from superlane_tools.recording.writers import open_writer

runner = CliRunner()
T0 = 1_700_000_000_000_000_000


def _drive(path: Path, n: int = 200) -> Path:
    with open_writer(path, "mcap", chunk_size=4096) as w:
        w.add_topic("/can", "can_msgs/msg/Frame")
        w.add_topic("/fix", "sensor_msgs/msg/NavSatFix")
        for i in range(n):
            t = T0 + i * 10_000_000
            w.write(
                "/can", t, m.can_frame(t, 0x100 + i % 2, bytes([i % 256] * (8 if i % 2 else 4)))
            )
            if i % 10 == 0:
                w.write("/fix", t, m.navsatfix(t, "gnss", 48.0, 11.0, 500.0))
        w.add_metadata("vehicle", {"name": "test car", "vin": "X"})
    return path


def test_info_reads_only_the_summary_by_default(tmp_path: Path) -> None:
    path = _drive(tmp_path / "d.mcap")
    result = runner.invoke(app, ["info", str(path), "--json"])
    assert result.exit_code == 0, result.output
    doc = json.loads(result.stdout)
    assert doc["read_from"] == "summary section"
    assert doc["message_count"] == 220
    topics = {t["topic"]: t for t in doc["topics"]}
    assert topics["/can"]["count"] == 200
    assert topics["/can"]["largest_gap_s"] is None  # needs --scan
    assert 90 < topics["/can"]["median_rate_hz"] < 110
    f = doc["file"]
    assert f["size_bytes"] == path.stat().st_size
    assert f["chunk_count"] > 1
    assert f["compression"] == ["zstd"]
    assert f["metadata"] == [{"name": "vehicle", "data": {"name": "test car", "vin": "X"}}]
    assert doc["can_ids"] == []


def test_info_scan_reads_every_message_and_lists_can_ids(tmp_path: Path) -> None:
    path = _drive(tmp_path / "d.mcap")
    result = runner.invoke(app, ["info", str(path), "--json", "--scan"])
    assert result.exit_code == 0, result.output
    doc = json.loads(result.stdout)
    assert doc["read_from"] == "every message"
    ids = {r["can_id"]: r for r in doc["can_ids"]}
    assert ids[0x100]["count"] == 100
    assert ids[0x100]["dlcs"] == [4]
    assert ids[0x101]["dlcs"] == [8]
    assert abs(ids[0x101]["rate_hz"] - 50.0) < 0.5
    table = runner.invoke(app, ["info", str(path)])
    assert "read from: summary section" in table.stdout
    assert "metadata vehicle: name=test car" in table.stdout


def test_median_with_zeros() -> None:
    import numpy as np

    assert median_with_zeros(np.array([5, 7, 9]), 0) == 7
    assert median_with_zeros(np.array([5, 7, 9]), 3) == 2.5
    assert median_with_zeros(np.array([5]), 4) == 0.0
    assert median_with_zeros(np.array([], dtype=int), 0) == 0.0


def test_rate_memory_does_not_grow_with_the_time_span() -> None:
    stats = _TopicStats()
    for i in range(5000):
        stats.add(T0 + i * 100_000_000, None)
    stats.add(T0 + 10 * 365 * 86_400 * 1_000_000_000, None)  # a clock jump of ten years
    tracemalloc.start()
    rate, _ = stats.median_rate_hz()
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    assert rate == 0.0  # nearly all 10 s windows of ten years are empty
    assert peak < 5_000_000  # bytes; one counter per 10 s window would be 250 MB


def test_info_lists_can_ids_of_a_real_candump_log(realdata: Path) -> None:
    log = realdata / "can_logs" / "ford_fusion" / "nothing.log"
    result = runner.invoke(app, ["info", str(log), "--json"])
    assert result.exit_code == 0, result.output
    doc = json.loads(result.stdout)
    assert doc["read_from"] == "every message"
    ids = {r["can_id"]: r for r in doc["can_ids"]}
    assert sum(r["count"] for r in ids.values()) == doc["message_count"]
    assert ids[0x47]["dlcs"] == [8]
    assert abs(ids[0x47]["rate_hz"] - 50.0) < 1.0


@pytest.mark.parametrize("scan", [False, True], ids=["summary", "scan"])
def test_no_rate_for_messages_at_one_time(tmp_path: Path, scan: bool) -> None:
    path = tmp_path / "burst.mcap"
    with open_writer(path, "mcap") as w:
        w.add_topic("/burst", "sensor_msgs/msg/NavSatFix")
        w.add_topic("/near", "sensor_msgs/msg/NavSatFix")
        for i in range(5):
            w.write("/burst", T0, m.navsatfix(T0, "gnss", 48.0, 11.0, 500.0 + i))
        for i in range(3):  # 400 ns in all: 5 MHz by (count - 1) / span
            w.write("/near", T0 + 200 * i, m.navsatfix(T0, "gnss", 48.0, 11.0, 500.0))
    args = ["info", str(path), *(["--scan"] if scan else [])]
    result = runner.invoke(app, [*args, "--json"])
    assert result.exit_code == 0, result.output
    topics = {t["topic"]: t for t in json.loads(result.stdout)["topics"]}
    for name in ("/burst", "/near"):
        assert topics[name]["median_rate_hz"] is None, topics[name]
        assert topics[name]["rate_note"], topics[name]
    if scan:
        assert "share one log time" in topics["/burst"]["rate_note"]
        assert "within 400 ns" in topics["/near"]["rate_note"]
    text = runner.invoke(app, args)
    assert text.exit_code == 0, text.output
    assert "rate -: /burst: all 5 messages" in text.stdout
    assert "rate -: /near: all 3 messages" in text.stdout
    assert "MHz" not in text.stdout
    for line in text.stdout.splitlines():
        if line.startswith(("│ /burst", "│ /near")):
            assert line.split("│")[5].strip() == "-", line
