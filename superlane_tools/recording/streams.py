"""Stream selection: which topics of a recording are camera frames, calibration, CAN and GNSS."""

from __future__ import annotations

import os
from collections.abc import Collection, Mapping, Sequence
from pathlib import Path
from typing import NamedTuple

from superlane_tools.errors import ConfigError, UsageError
from superlane_tools.recording.base import ros2_msgtype
from superlane_tools.recording.video import VIDEO_MSGTYPES
from superlane_tools.records import TopicInfo

FRAME_TYPES = frozenset(
    {
        "sensor_msgs/msg/Image",
        "sensor_msgs/msg/CompressedImage",
        "foxglove.CompressedImage",
        "foxglove.RawImage",
        *VIDEO_MSGTYPES,
    }
)
"""Message types holding camera images (still images and compressed video)."""
RAW_IMAGE_TYPES = frozenset({"sensor_msgs/msg/Image", "foxglove.RawImage"})
"""Image message types with uncompressed pixels (the rest hold JPEG or PNG payloads)."""
CAMERA_INFO_TYPES = frozenset({"sensor_msgs/msg/CameraInfo", "foxglove.CameraCalibration"})
CAN_TYPES = frozenset({"can_msgs/msg/Frame"})
GNSS_TYPES = frozenset({"sensor_msgs/msg/NavSatFix", "foxglove.LocationFix"})
IMU_TYPES = frozenset({"sensor_msgs/msg/Imu"})
TF_TYPES = frozenset({"tf2_msgs/msg/TFMessage"})
STREAM_KINDS = ("frames", "camera_info", "can", "gnss")
_KIND_TYPES = {
    "frames": FRAME_TYPES,
    "camera_info": CAMERA_INFO_TYPES,
    "can": CAN_TYPES,
    "gnss": GNSS_TYPES,
}
TOPIC_KIND_TYPES: Mapping[str, frozenset[str]] = {**_KIND_TYPES, "imu": IMU_TYPES}
"""Message types each configurable topic (a stream kind, or ``imu``) accepts."""


def check_topic_kinds(
    topics: Sequence[TopicInfo], wanted: Mapping[str, Sequence[str]], where: str = ""
) -> None:
    """Check that each named topic has a message type its kind can read.

    Args:
        topics: The recording's topics.
        wanted: Kind (a stream kind or ``imu``) -> topics named for it; topics missing from
            the recording are left to the caller.
        where: Prefix naming the option or config, e.g. ``"--config c.yaml: "``.

    Raises:
        UsageError: If a topic's type is not one its kind reads (``can: /fix`` on a NavSatFix).
    """
    available = {t.topic: t.msgtype for t in topics}
    for kind, names in wanted.items():
        expected = TOPIC_KIND_TYPES.get(kind)
        if expected is None:
            raise ConfigError(f"{where}unknown topic kind {kind!r}: use {tuple(TOPIC_KIND_TYPES)}")
        for name in names:
            msgtype = available.get(name)
            if msgtype is None or ros2_msgtype(msgtype) in expected:
                continue
            takes = (
                " ".join(expected)
                if len(expected) == 1
                else f"one of {', '.join(sorted(expected))}"
            )
            raise UsageError(
                f"{where}{kind} topic {name} has type {msgtype or 'unknown'}; {kind} takes {takes}"
            )


class Streams(NamedTuple):
    """One topic per stream ("" when the recording has none), and notes on the choice."""

    frames: str
    camera_info: str
    can: str
    gnss: str
    tf: str
    notes: tuple[str, ...]


def load_stream_config(path: str | os.PathLike[str]) -> dict[str, tuple[str, ...]]:
    """Read a YAML config ``{frames: [...], camera_info: [...], can: [...], gnss: [...]}``.

    Raises:
        ConfigError: If the file is unreadable, not a mapping, or has unknown keys or non-list
            values.
    """
    from superlane_tools.config_files import load_mapping

    src = Path(path)
    raw = load_mapping(src, "extract config", suffix=".yaml")
    streams: dict[str, tuple[str, ...]] = {}
    for key, value in raw.items():
        if key not in STREAM_KINDS:
            raise ConfigError(f"{src}: unknown key {key!r}; expected {STREAM_KINDS}")
        items = [value] if isinstance(value, str) else value
        if not isinstance(items, list) or not all(isinstance(t, str) for t in items):
            raise ConfigError(f"{src}: {key} must be a list of topic names")
        streams[key] = tuple(items)
    return streams


def _check_present(topics: Sequence[TopicInfo], wanted: Collection[str]) -> None:
    available = sorted(t.topic for t in topics)
    missing = sorted(set(wanted) - set(available))
    if missing:
        listing = ", ".join(available) or "none"
        raise UsageError(f"topics not in the recording: {', '.join(missing)} (it has: {listing})")


def select_streams(
    topics: Sequence[TopicInfo],
    only: Collection[str] = (),
    streams: Mapping[str, Sequence[str]] | None = None,
) -> dict[str, tuple[str, ...]]:
    """Assign topics to kinds by message type.

    Args:
        topics: The recording's topics.
        only: Restrict to these topics (streams still found by message type); empty: all.
        streams: Explicit topic lists per kind; a kind listed here is not auto-detected.

    Returns:
        Kind -> topics, for every kind of :data:`STREAM_KINDS`.

    Raises:
        UsageError: If a requested topic is not in the recording, or a kind's topic has a
            message type that kind cannot read.
    """
    explicit = dict(streams or {})
    unknown = set(explicit) - set(STREAM_KINDS)
    if unknown:
        raise ConfigError(f"unknown stream kinds {sorted(unknown)}: use {STREAM_KINDS}")
    available = {t.topic: t.msgtype for t in topics}
    _check_present(topics, [*only, *(t for ts in explicit.values() for t in ts)])
    check_topic_kinds(topics, explicit)
    allowed = set(only) if only else set(available)
    selected: dict[str, tuple[str, ...]] = {}
    claimed = {t for ts in explicit.values() for t in ts}
    for kind in STREAM_KINDS:
        if kind in explicit:
            selected[kind] = tuple(explicit[kind])
            continue
        types = _KIND_TYPES[kind]
        selected[kind] = tuple(
            sorted(
                t for t, m in available.items() if m in types and t in allowed and t not in claimed
            )
        )
    return selected


def message_total(topics: Sequence[TopicInfo], selected: Collection[str]) -> int | None:
    """Return the messages on the selected topics (None when a count is unknown)."""
    counts = [t.message_count for t in topics if t.topic in selected]
    if any(c is None for c in counts):
        return None
    return sum(c for c in counts if c is not None)


def topics_of_type(topics: Sequence[TopicInfo], msgtype: str) -> set[str]:
    """Return the topics of one message type (ROS 1 / ROS 2 spellings alike)."""
    short = msgtype.replace("/msg/", "/")
    return {t.topic for t in topics if t.msgtype in (msgtype, short)}


def select_one_each(topics: Sequence[TopicInfo], wanted: Mapping[str, str]) -> Streams:
    """Pick one topic per stream kind: the configured one, else the first of its message type.

    Args:
        topics: The recording's topics.
        wanted: Kind -> configured topic ("" or absent: found by message type); an ``imu`` key
            is checked too (it exists and is an IMU topic) but not selected here.

    Raises:
        UsageError: If a configured topic is missing from the recording or has a message type
            its kind cannot read.
    """
    named = {k: (t,) for k, t in wanted.items() if t}
    imu = named.pop("imu", ())
    selected = select_streams(topics, streams=named)
    if imu:
        _check_present(topics, imu)
        check_topic_kinds(topics, {"imu": imu})
    notes = []
    picked: dict[str, str] = {}
    for kind in STREAM_KINDS:
        found = selected.get(kind, ())
        picked[kind] = found[0] if found else ""
        if len(found) > 1:
            notes.append(f"several {kind} topics ({', '.join(found)}): using {found[0]}")
    tf = next((t.topic for t in topics if t.msgtype in TF_TYPES), "")
    return Streams(
        picked["frames"], picked["camera_info"], picked["can"], picked["gnss"], tf, tuple(notes)
    )
