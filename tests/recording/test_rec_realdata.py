"""Real public bags: ROS 1 robot_localization bags and rosbag2's own format fixtures."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

from superlane_tools.cli.app import app
from superlane_tools.recording import open_recording

FIXTURES = [
    ("ros2_format_fixtures/cdr_test", 7),
    ("ros2_format_fixtures/mcap/wbag", 6074),
    ("ros2_format_fixtures/sqlite3/wbag", 6074),
    ("ros2_format_fixtures/mcap/talker", 20),
    ("ros2_format_fixtures/sqlite3/talker", 20),
    ("ros2_format_fixtures/cdr_test/cdr_test_0.mcap", 7),
    ("ros2_format_fixtures/mcap/talker/talker.mcap", 20),
]


def test_ros1_bag_navsatfix(realdata: Path) -> None:
    path = realdata / "bags/ros1_robot_localization/test1.bag"
    with open_recording(path) as rec:
        topics = {t.topic: t for t in rec.topics()}
        assert topics["/fix"].msgtype == "sensor_msgs/msg/NavSatFix"
        assert topics["/fix"].message_count == 989
        fixes = list(rec.messages(topics=["/fix"]))
        assert rec.skipped == []
    assert len(fixes) == 989
    assert all(f.stamp_ns is not None for f in fixes)
    lats = [f.data.latitude for f in fixes]
    assert max(lats) - min(lats) < 0.01  # ~146 m x 57 m area
    times = [f.log_time_ns for f in fixes]
    assert times == sorted(times)


@pytest.mark.parametrize(("rel", "count"), FIXTURES, ids=[f[0] for f in FIXTURES])
def test_rosbag2_fixtures_open_and_stream(realdata: Path, rel: str, count: int) -> None:
    with open_recording(realdata / "bags" / rel) as rec:
        msgs = list(rec.messages())
        skipped = rec.skipped
    assert len(msgs) == count
    assert skipped == []
    times = [m.log_time_ns for m in msgs]
    assert times == sorted(times)
    strings = [m.data.data for m in msgs if m.msgtype == "std_msgs/msg/String"]
    assert all(isinstance(s, str) for s in strings)


def test_split_bag_topics_and_values(realdata: Path) -> None:
    sqlite = realdata / "bags/ros2_format_fixtures/sqlite3/wbag"
    mcap = realdata / "bags/ros2_format_fixtures/mcap/wbag"
    with open_recording(sqlite) as a, open_recording(mcap) as b:
        assert a.topics() == b.topics()
        first_a = [(m.topic, m.log_time_ns, m.data.data) for m in a.messages(topics=["AAA"])]
        first_b = [(m.topic, m.log_time_ns, m.data.data) for m in b.messages(topics=["AAA"])]
    assert first_a == first_b
    assert len(first_a) == 804


@pytest.mark.parametrize(
    "rel",
    [
        "ros1_robot_localization/test1.bag",
        "ros1_robot_localization/test2.bag",
        "ros2_format_fixtures/sqlite3/wbag",
        "ros2_format_fixtures/mcap/talker",
        "ros2_format_fixtures/cdr_test",
    ],
)
def test_slt_info_on_real_bags(realdata: Path, rel: str) -> None:
    result = CliRunner().invoke(app, ["info", str(realdata / "bags" / rel), "--json"])
    assert result.exit_code == 0, result.output
    doc = json.loads(result.stdout)
    assert doc["message_count"] > 0
    if rel.endswith("test1.bag"):
        fix = next(t for t in doc["topics"] if t["topic"] == "/fix")
        assert fix["count"] == 989
        assert fix["median_rate_hz"] == pytest.approx(2.5, abs=0.1)
        assert fix["median_stamp_offset_ms"] is not None
