"""Stream selection, `Recording.metadata()` and the camera metadata codec on real files."""

from __future__ import annotations

from pathlib import Path

import pytest

from superlane_tools.camera.metadata import (
    METADATA_NAME,
    camera_metadata,
    extrinsics_from_metadata,
)
from superlane_tools.camera.profiles import load_camera
from superlane_tools.errors import ConfigError, UsageError
from superlane_tools.recording import open_recording
from superlane_tools.recording.calibration import resolve_camera
from superlane_tools.recording.streams import select_one_each, select_streams
from superlane_tools.records import TopicInfo
from superlane_tools.simulation.drive import simulate_drive

TOPICS = [
    TopicInfo("/cam/a", "sensor_msgs/msg/CompressedImage", "cdr", 10),
    TopicInfo("/cam/b", "foxglove.RawImage", "protobuf", 10),
    TopicInfo("/info", "sensor_msgs/msg/CameraInfo", "cdr", 1),
    TopicInfo("/can", "can_msgs/msg/Frame", "cdr", 100),
    TopicInfo("/fix", "sensor_msgs/msg/NavSatFix", "cdr", 10),
    TopicInfo("/tf_static", "tf2_msgs/msg/TFMessage", "cdr", 1),
]


def test_select_streams_by_type_restricted_and_explicit() -> None:
    found = select_streams(TOPICS)
    assert found == {
        "frames": ("/cam/a", "/cam/b"),
        "camera_info": ("/info",),
        "can": ("/can",),
        "gnss": ("/fix",),
    }
    assert select_streams(TOPICS, only=["/cam/b", "/fix"])["frames"] == ("/cam/b",)
    explicit = select_streams(TOPICS, streams={"frames": ("/cam/b",)})
    assert explicit["frames"] == ("/cam/b",)
    with pytest.raises(UsageError, match="topics not in the recording: /nope"):
        select_streams(TOPICS, only=["/nope"])
    with pytest.raises(ConfigError, match="unknown stream kinds"):
        select_streams(TOPICS, streams={"lidar": ("/cam/a",)})


def test_select_one_each_notes_a_choice_and_finds_tf() -> None:
    streams = select_one_each(TOPICS, {"frames": "", "gnss": "/fix"})
    assert streams.frames == "/cam/a"
    assert streams.tf == "/tf_static"
    assert streams.notes == ("several frames topics (/cam/a, /cam/b): using /cam/a",)
    assert select_one_each(TOPICS, {"frames": "/cam/b"}).notes == ()


def test_wrong_kind_topics_are_usage_errors() -> None:
    with pytest.raises(UsageError, match="can topic /fix has type sensor_msgs/msg/NavSatFix"):
        select_streams(TOPICS, streams={"can": ["/fix"]})
    with pytest.raises(UsageError, match=r"frames topic /info has type .*; frames takes one of"):
        select_one_each(TOPICS, {"frames": "/info"})
    imu = [*TOPICS, TopicInfo("/imu", "sensor_msgs/Imu", "ros1msg", 10)]  # ROS 1 spelling
    assert select_one_each(imu, {"imu": "/imu", "can": "/can"}).can == "/can"
    with pytest.raises(
        UsageError, match=r"imu topic /fix has type .*; imu takes sensor_msgs/msg/Imu"
    ):
        select_one_each(imu, {"imu": "/fix"})
    with pytest.raises(UsageError, match="not in the recording: /nope"):
        select_one_each(imu, {"imu": "/nope"})


def test_camera_metadata_round_trip() -> None:
    camera = load_camera("sim_default")
    record = camera_metadata(camera, "base_link", "camera_optical")
    assert all(isinstance(v, str) for v in record.values())
    assert extrinsics_from_metadata(record) == camera.extrinsics


def test_recording_metadata_gives_the_camera(tmp_path: Path) -> None:
    mcap = tmp_path / "d.mcap"
    simulate_drive("highway_curves", 0.4, 1, "mcap", 160, 90, False, mcap)
    bag = tmp_path / "d.bag"
    simulate_drive("highway_curves", 0.4, 1, "ros1", 160, 90, False, bag)
    camera = load_camera("sim_default")
    with open_recording(mcap) as rec:
        record = rec.metadata()[METADATA_NAME]
        assert extrinsics_from_metadata(record) == camera.extrinsics
        streams = select_one_each(rec.topics(), {})
        found, source = resolve_camera(rec, streams, "auto")
    assert "MCAP metadata slt_camera" in source
    assert found.extrinsics == camera.extrinsics
    with open_recording(bag) as rec:
        assert rec.metadata() == {}  # ROS 1 bags have no metadata records: /tf_static instead
        found, source = resolve_camera(rec, select_one_each(rec.topics(), {}), "auto")
    assert "/tf_static" in source
    assert found.extrinsics.height_m == pytest.approx(camera.extrinsics.height_m)
