"""A topic of the wrong kind in any topic option or config key is a usage error (exit 2, one line).

Runs every command that takes a topic on the real ROS 1 bag ``test1.bag`` (``/fix`` NavSatFix,
``/imu/data`` Imu, ``/husky_velocity_controller/odom`` Odometry).
"""

from __future__ import annotations

from pathlib import Path

import pytest
from typer.testing import CliRunner

from superlane_tools.cli.app import app

runner = CliRunner()
WRONG = [  # (kind, topic of another kind, its type)
    ("can", "/fix", "sensor_msgs/msg/NavSatFix"),
    ("gnss", "/imu/data", "sensor_msgs/msg/Imu"),
    ("frames", "/fix", "sensor_msgs/msg/NavSatFix"),
    ("camera_info", "/husky_velocity_controller/odom", "nav_msgs/msg/Odometry"),
]


@pytest.fixture(scope="module")
def bag(realdata: Path) -> Path:
    return realdata / "bags" / "ros1_robot_localization" / "test1.bag"


def _usage_error(args: list[str], kind: str, topic: str, msgtype: str) -> None:
    res = runner.invoke(app, args, catch_exceptions=False)
    assert res.exit_code == 2, res.output
    errors = [ln for ln in res.output.splitlines() if ln.startswith("slt: error:")]
    assert len(errors) == 1, res.output
    assert f"{kind} topic {topic} has type {msgtype}; {kind} takes " in errors[0]
    assert "internal error" not in res.output
    assert "Traceback" not in res.output


@pytest.mark.parametrize(("kind", "topic", "msgtype"), WRONG)
def test_extract_config_wrong_kind(
    bag: Path, tmp_path: Path, kind: str, topic: str, msgtype: str
) -> None:
    config = tmp_path / "c.yaml"
    config.write_text(f"{kind}: [{topic}]\n")
    out = tmp_path / "out"
    _usage_error(
        ["extract", str(bag), "--config", str(config), "--out", str(out)], *(kind, topic, msgtype)
    )
    assert not any(out.glob("*.parquet"))


@pytest.mark.parametrize(
    ("kind", "topic", "msgtype"), [*WRONG, ("imu", "/fix", "sensor_msgs/msg/NavSatFix")]
)
def test_reprocess_config_wrong_kind(
    bag: Path, tmp_path: Path, kind: str, topic: str, msgtype: str
) -> None:
    config = tmp_path / "r.toml"
    config.write_text(f'[topics]\n{kind} = "{topic}"\n')
    out = tmp_path / "out"
    _usage_error(
        ["reprocess", str(bag), "--config", str(config), "--out", str(out)], *(kind, topic, msgtype)
    )


def test_camera_estimate_topic_wrong_kind(bag: Path, tmp_path: Path) -> None:
    args = ["camera", "estimate", str(bag), "--topic", "/fix"]
    _usage_error(args, "frames", "/fix", "sensor_msgs/msg/NavSatFix")


@pytest.mark.slow
def test_batch_job_with_wrong_kind_fails_that_recording(bag: Path, tmp_path: Path) -> None:
    config = tmp_path / "c.yaml"
    config.write_text("streams:\n  can: [/fix]\n")
    args = ["batch", str(bag), "--job", "extract", "--config", str(config), "--retries", "0"]
    res = runner.invoke(app, [*args, "--out", str(tmp_path / "out")], catch_exceptions=False)
    assert res.exit_code == 1, res.output
    assert "can topic /fix has type sensor_msgs/msg/NavSatFix; can takes can_msgs/msg/Frame" in (
        res.output
    )
    assert "internal error" not in res.output
