"""The streaming recording interface every source implements, and helpers they share."""

from __future__ import annotations

import struct
from collections.abc import Collection, Iterator
from pathlib import Path
from types import TracebackType
from typing import Any, Protocol, Self, runtime_checkable

from superlane_tools.records import Message, RawMessage, Skipped, TopicInfo

_CDR_STAMP = struct.Struct("<iI")
_CDR_STAMP_BE = struct.Struct(">iI")
_ROS1_STAMP = struct.Struct("<II")


@runtime_checkable
class Recording(Protocol):
    """A recording opened for streaming: MCAP file, ROS 1 bag, ROS 2 bag, CAN or NMEA log.

    Messages come in log-time order and are read lazily, so memory stays flat for any recording
    length. Time ranges are ``[start_ns, stop_ns)`` on log time (integer ns since the epoch).
    Use it as a context manager, or call :meth:`close`.
    """

    path: Path

    @property
    def skipped(self) -> list[Skipped]:
        """What was skipped or lost so far: unknown types, corrupt chunks, truncation."""
        ...

    def topics(self) -> list[TopicInfo]:
        """Return the topics the recording declares, sorted by topic name."""
        ...

    def messages(
        self,
        topics: Collection[str] | None = None,
        start_ns: int | None = None,
        stop_ns: int | None = None,
    ) -> Iterator[Message]:
        """Yield decoded messages of ``topics`` (all if None) with log time in the range."""
        ...

    def raw_messages(
        self,
        topics: Collection[str] | None = None,
        start_ns: int | None = None,
        stop_ns: int | None = None,
    ) -> Iterator[RawMessage]:
        """Yield undecoded messages, like :meth:`messages` but without the decoding step."""
        ...

    def metadata(self) -> dict[str, dict[str, str]]:
        """Return the recording's metadata records by name (MCAP metadata; empty elsewhere)."""
        ...

    def close(self) -> None:
        """Release the files the recording holds open."""
        ...

    def __enter__(self) -> Self: ...

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None: ...


class ClosingRecording:
    """Mixin for recording sources: ``with source:`` closes it on exit."""

    def metadata(self) -> dict[str, dict[str, str]]:
        """Return the metadata records by name: none unless the format has them."""
        return {}

    def close(self) -> None:
        """Release open files (subclasses override)."""

    def __enter__(self) -> Self:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()


@runtime_checkable
class SupportsStampPeek(Protocol):
    """A recording that can read a raw message's header stamp without a full decode."""

    def peek_stamp_ns(self, raw: RawMessage) -> int | None:
        """Return the header stamp (ns) of ``raw``, or None when its type has no header."""
        ...


class SkipLog:
    """Counts skipped items by (what, detail): one :class:`Skipped` entry per kind and topic."""

    def __init__(self) -> None:
        self._counts: dict[tuple[str, str], int] = {}

    def add(self, what: str, detail: str, n_items: int = 1) -> None:
        """Record ``n_items`` more items skipped for ``what`` / ``detail``."""
        key = (what, detail)
        self._counts[key] = self._counts.get(key, 0) + n_items

    def clear(self) -> None:
        """Forget everything recorded."""
        self._counts.clear()

    def items(self) -> list[Skipped]:
        """Return the entries in the order they were first recorded."""
        return [Skipped(what, detail, n) for (what, detail), n in self._counts.items()]

    def __bool__(self) -> bool:
        return bool(self._counts)


def ros2_msgtype(name: str) -> str:
    """Return a ROS message type name in ROS 2 form: ``pkg/Name`` becomes ``pkg/msg/Name``."""
    parts = name.split("/")
    if len(parts) == 2 and all(parts):
        return f"{parts[0]}/msg/{parts[1]}"
    return name


LOG_TIME_MAX_NS = 2**63 - 1
"""Largest log time the toolkit stores: int64 ns (year 2262). MCAP allows uint64."""


def storable_time(log_time_ns: int) -> bool:
    """Return True when a log time fits the int64 ns columns of every output table."""
    return 0 <= log_time_ns <= LOG_TIME_MAX_NS


def time_range_ns(
    rec: Recording, topics: Collection[str], start_s: float | None, end_s: float | None
) -> tuple[int | None, int | None]:
    """Return ``[start, stop)`` log times, ns, of offsets in seconds after the first message.

    Args:
        rec: The recording.
        topics: Topics whose first message is time zero.
        start_s: Start offset, seconds (None: from the beginning).
        end_s: End offset, seconds, exclusive (None: to the end).

    Returns:
        ``(start_ns, stop_ns)``, None where open (also both None when the topics hold nothing).
    """
    if start_s is None and end_s is None:
        return None, None
    first = next((raw.log_time_ns for raw in rec.raw_messages(topics=topics)), None)
    if first is None:
        return None, None
    start_ns = None if start_s is None else first + round(start_s * 1_000_000_000)
    stop_ns = None if end_s is None else first + round(end_s * 1_000_000_000)
    return start_ns, stop_ns


def in_range(log_time_ns: int, start_ns: int | None, stop_ns: int | None) -> bool:
    """Return True when ``log_time_ns`` lies in ``[start_ns, stop_ns)`` (None: unbounded)."""
    return (start_ns is None or log_time_ns >= start_ns) and (
        stop_ns is None or log_time_ns < stop_ns
    )


def _time_ns(stamp: Any) -> int | None:
    """Convert a ROS or protobuf time object to integer ns, or None if it is not one."""
    for sec_name, nsec_name in (("sec", "nanosec"), ("secs", "nsecs"), ("seconds", "nanos")):
        sec = getattr(stamp, sec_name, None)
        nsec = getattr(stamp, nsec_name, None)
        if isinstance(sec, int) and isinstance(nsec, int):
            value = sec * 1_000_000_000 + nsec
            return value if -LOG_TIME_MAX_NS <= value <= LOG_TIME_MAX_NS else None
    return None


def field_value(data: Any, *names: str) -> Any:
    """Return the first of ``names`` that ``data`` has and is not None (else None).

    Decoded messages name the same field differently by source: ROS 1 ``K`` vs ROS 2 ``k``,
    ROS ``format`` vs Foxglove protobuf ``format``/``encoding``.
    """
    for name in names:
        value = getattr(data, name, None)
        if value is not None:
            return value
    return None


def stamp_ns_of(data: Any) -> int | None:
    """Return a decoded message's own time stamp in ns, or None.

    ``header.stamp`` for ROS 1 and ROS 2 messages (also JSON messages shaped like them),
    ``timestamp`` for Foxglove protobuf messages. A protobuf message whose ``timestamp`` field is
    unset has no stamp.
    """
    header = getattr(data, "header", None)
    if header is not None:
        stamp = getattr(header, "stamp", None)
        if stamp is not None:
            return _time_ns(stamp)
    timestamp = getattr(data, "timestamp", None)
    if timestamp is None:
        return None
    has_field = getattr(data, "HasField", None)
    if callable(has_field):
        try:
            if not has_field("timestamp"):
                return None
        except ValueError:
            return None
    return _time_ns(timestamp)


def raw_header_stamp_ns(encoding: str, payload: bytes) -> int | None:
    """Read ``header.stamp`` (ns) from the start of a serialized message whose first field is it.

    Only call this for message types that start with ``std_msgs/Header``: CDR puts
    ``int32 sec, uint32 nanosec`` after the 4-byte encapsulation header; ROS 1 puts
    ``uint32 seq, uint32 secs, uint32 nsecs`` first.

    Args:
        encoding: ``cdr`` or ``ros1``.
        payload: The serialized message.

    Returns:
        The stamp in ns, or None for another encoding or a too-short payload.
    """
    if encoding == "cdr" and len(payload) >= 12:
        little = payload[1] & 1
        sec, nsec = (_CDR_STAMP if little else _CDR_STAMP_BE).unpack_from(payload, 4)
        return int(sec) * 1_000_000_000 + int(nsec)
    if encoding == "ros1" and len(payload) >= 12:
        sec, nsec = _ROS1_STAMP.unpack_from(payload, 4)
        return int(sec) * 1_000_000_000 + int(nsec)
    return None


def msgdef_starts_with_header(msgdef: str) -> bool:
    """Return True when a ``.msg`` text's first field is a ``std_msgs/Header header``."""
    for line in msgdef.splitlines():
        text = line.split("#", 1)[0].strip()
        if not text:
            continue
        if text.startswith("MSG:") or text.startswith("==="):
            return False
        fields = text.split()
        if len(fields) >= 2 and "=" in text:
            continue  # a constant, not a field
        return len(fields) >= 2 and fields[0] in {
            "Header",
            "std_msgs/Header",
            "std_msgs/msg/Header",
        }
    return False
