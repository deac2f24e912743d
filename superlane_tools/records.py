"""Small records shared by every layer: messages from recordings and skip reports."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, NamedTuple

Progress = Callable[[int, int | None], None]
"""Progress callback of a pass over items: ``(items done, items total or None)``."""


class Message(NamedTuple):
    """One decoded message from a recording, the unit of the streaming API.

    Attributes:
        topic: Topic (or CAN bus / log channel) name.
        log_time_ns: Time the message was logged, integer nanoseconds since the Unix epoch.
        stamp_ns: ``header.stamp`` in integer nanoseconds when the message has a header, else None.
        msgtype: Message type name in ROS 2 form, e.g. ``sensor_msgs/msg/NavSatFix``.
        data: The decoded message object (attribute access like the ROS message fields).
    """

    topic: str
    log_time_ns: int
    stamp_ns: int | None
    msgtype: str
    data: Any


class RawMessage(NamedTuple):
    """One undecoded message: what readers yield before the pluggable decoding step."""

    topic: str
    log_time_ns: int
    msgtype: str
    encoding: str
    payload: bytes


class TopicInfo(NamedTuple):
    """What a recording declares about one topic.

    Attributes:
        topic: Topic name.
        msgtype: Message type name in ROS 2 form (``pkg/msg/Name``).
        encoding: Message encoding (``cdr``, ``ros1``, ``protobuf``, ``json``, ``can``, ``nmea``).
        message_count: Number of messages, when the container knows it without a scan, else None.
    """

    topic: str
    msgtype: str
    encoding: str
    message_count: int | None


class Skipped(NamedTuple):
    """Something that was skipped or lost while reading, for the partial-result report.

    Attributes:
        what: Short kind, e.g. ``unknown message type``, ``corrupt chunk``, ``truncated file``.
        detail: Human-readable detail (topic, offset, reason).
        n_items: How many messages or items it concerns (0 when unknown).
    """

    what: str
    detail: str
    n_items: int = 0
