"""Stream selection: which topics of a recording are camera frames, calibration, CAN and GNSS."""

from __future__ import annotations

import os
from collections.abc import Collection, Mapping, Sequence
from pathlib import Path
from typing import NamedTuple

from superlane_tools.errors import ConfigError, UsageError
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
TF_TYPES = frozenset({"tf2_msgs/msg/TFMessage"})
STREAM_KINDS = ("frames", "camera_info", "can", "gnss")
_KIND_TYPES = {
    "frames": FRAME_TYPES,
    "camera_info": CAMERA_INFO_TYPES,
    "can": CAN_TYPES,
    "gnss": GNSS_TYPES,
}


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
        UsageError: If a requested topic is not in the recording.
    """
    explicit = dict(streams or {})
    unknown = set(explicit) - set(STREAM_KINDS)
    if unknown:
        raise ConfigError(f"unknown stream kinds {sorted(unknown)}: use {STREAM_KINDS}")
    available = {t.topic: t.msgtype for t in topics}
    wanted = [*only, *(t for ts in explicit.values() for t in ts)]
    missing = sorted({t for t in wanted if t not in available})
    if missing:
        listing = ", ".join(sorted(available)) or "none"
        raise UsageError(f"topics not in the recording: {', '.join(missing)} (it has: {listing})")
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
        wanted: Kind -> configured topic ("" or absent: found by message type).

    Raises:
        UsageError: If a configured topic is missing from the recording.
    """
    selected = select_streams(topics, streams={k: (t,) for k, t in wanted.items() if t})
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
