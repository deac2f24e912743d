"""`slt info` through the real CLI app: table, JSON, exit codes."""

from __future__ import annotations

import json
from pathlib import Path
from types import SimpleNamespace

import pytest
from typer.testing import CliRunner

from superlane_tools.cli.app import app
from superlane_tools.recording import open_recording, summarize

runner = CliRunner()


def test_info_table(drive: SimpleNamespace) -> None:
    path = drive.write("drive.mcap", "mcap")
    result = runner.invoke(app, ["info", str(path)])
    assert result.exit_code == 0, result.output
    assert "/gnss/fix" in result.output
    assert "can_msgs/msg/Frame" in result.output
    assert f"{drive.total} messages" in result.output


@pytest.mark.parametrize(("name", "fmt"), [("drive.bag", "ros1"), ("drive_ros2", "ros2")])
def test_info_json(drive: SimpleNamespace, name: str, fmt: str) -> None:
    path = drive.write(name, fmt)
    result = runner.invoke(app, ["info", str(path), "--json"])
    assert result.exit_code == 0, result.output
    doc = json.loads(result.stdout)
    topics = {t["topic"]: t for t in doc["topics"]}
    assert doc["message_count"] == drive.total
    assert doc["container"] == fmt
    assert doc["skipped"] == []
    fix = topics["/gnss/fix"]
    assert fix["count"] == drive.n_steps
    assert fix["median_rate_hz"] == pytest.approx(10.0)
    assert fix["largest_gap_s"] == pytest.approx(0.1)
    assert fix["median_stamp_offset_ms"] == pytest.approx(-(drive.stamp_lag_ns + 1) / 1e6)
    assert fix["duration_s"] == pytest.approx((drive.n_steps - 1) * 0.1)
    assert topics["/tf_static"]["median_rate_hz"] is None


def test_info_exit_3_when_something_was_skipped(drive: SimpleNamespace, tmp_path: Path) -> None:
    path = drive.write("drive.mcap", "mcap", chunk_size=4096)
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(path.read_bytes()[: path.stat().st_size // 2])
    result = runner.invoke(app, ["info", str(cut), "--json"])
    assert result.exit_code == 3, result.output
    assert "slt: skipped: truncated file" in result.stderr
    # the damaged file is named with the command that salvages it
    assert "slt recover cut.mcap -o cut.recovered.mcap writes a valid copy" in result.stderr
    doc = json.loads(result.stdout)
    assert doc["skipped"][0]["what"] == "truncated file"
    assert 0 < doc["message_count"] < drive.total


def test_info_non_recording_is_one_line_exit_1(tmp_path: Path) -> None:
    path = tmp_path / "notes.txt"
    path.write_text("hello\n")
    result = runner.invoke(app, ["info", str(path)])
    assert result.exit_code == 1
    assert result.stderr.strip().startswith("slt: error: ")
    assert "is not a recording" in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1
    assert "Traceback" not in result.output


def test_info_usage_error_exit_2() -> None:
    result = runner.invoke(app, ["info", "--no-such-option", "x"])
    assert result.exit_code == 2


def test_summarize_matches_declared_counts(drive: SimpleNamespace) -> None:
    path = drive.write("drive_mcapstore", "ros2", "mcap")
    seen: list[int] = []
    with open_recording(path) as rec:
        summary = summarize(rec, progress=seen.append)
    assert seen[-1] == drive.total
    assert {t.topic: t.count for t in summary.topics} == drive.counts
    assert summary.duration_s == pytest.approx((drive.n_steps - 1) * 0.1 + 4e-9)
