"""CAN log files (candump ``-l`` ``.log``, Vector ``.asc``, ``.blf``) as a streaming recording."""

from __future__ import annotations

import os
import re
import struct
from collections.abc import Collection, Iterator
from pathlib import Path
from typing import Any, NamedTuple

from superlane_tools.recording.base import ClosingRecording, SkipLog, in_range
from superlane_tools.recording.errors import RecordingError
from superlane_tools.records import Message, RawMessage, Skipped, TopicInfo

CAN_FRAME_TYPE = "can_msgs/msg/Frame"
CANLOG_SUFFIXES = (".log", ".asc", ".blf")
DEFAULT_TOPIC = "can"

_RAW_HEADER = struct.Struct(">IB")
_EXTENDED_FLAG = 0x80000000
_CANDUMP_LINE = re.compile(
    r"^\s*\(\d+(?:\.\d+)?\)\s+\S+\s+[0-9A-Fa-f]{1,8}#"
    r"(?:#[0-9A-Fa-f])?(?:(?:[0-9A-Fa-f]{2})*|[Rr]\d?)(?:\s+[RrTt])?\s*$"
)
_ASC_START = re.compile(rb"^\s*(date|base|internal events|begin triggerblock)", re.IGNORECASE)


class CanFrame(NamedTuple):
    """One CAN frame, field-compatible with ``can_msgs/msg/Frame``.

    Attributes:
        id: Arbitration id (11 or 29 bits, no flag bits).
        is_extended: True for a 29-bit id.
        is_rtr: True for a remote transmission request.
        is_error: True for an error frame.
        dlc: Data length code (payload bytes for classic CAN).
        data: Payload bytes.
    """

    id: int
    is_extended: bool
    is_rtr: bool
    is_error: bool
    dlc: int
    data: bytes


def encode_raw_frame(frame: CanFrame) -> bytes:
    """Serialize a frame for :meth:`CanLogRecording.raw_messages`.

    Layout: big-endian uint32 id (bit 31 = extended, bit 30 = RTR, bit 29 = error frame, as in
    SocketCAN), uint8 dlc, then the payload bytes.
    """
    flags = (_EXTENDED_FLAG if frame.is_extended else 0) | (0x40000000 if frame.is_rtr else 0)
    flags |= 0x20000000 if frame.is_error else 0
    return _RAW_HEADER.pack(flags | (frame.id & 0x1FFFFFFF), frame.dlc & 0xFF) + frame.data


def looks_like_canlog(path: str | os.PathLike[str]) -> bool:
    """Return True when ``path`` is a CAN log python-can reads (by suffix and first bytes)."""
    src = Path(path)
    suffix = src.suffix.lower()
    if not src.is_file() or suffix not in CANLOG_SUFFIXES:
        return False
    try:
        with src.open("rb") as handle:
            head = handle.read(4096)
    except OSError:
        return False
    if suffix == ".blf":
        return head.startswith(b"LOGG")
    if suffix == ".asc":
        return any(_ASC_START.match(line) for line in head.splitlines()[:20])
    for line in head.splitlines()[:20]:
        text = line.decode("ascii", errors="replace").strip()
        if text:
            return bool(_CANDUMP_LINE.match(text))
    return False


class _CheckedLines:
    """A text file that hands python-can only well-formed candump lines; counts the rest."""

    def __init__(self, path: Path, skips: SkipLog) -> None:
        self._handle = path.open("r", encoding="ascii", errors="replace")
        self._skips = skips
        self._name = path.name

    def __iter__(self) -> Iterator[str]:
        for number, line in enumerate(self._handle, start=1):
            if not line.strip():
                continue
            if _CANDUMP_LINE.match(line):
                yield line
            else:
                self._skips.add("bad CAN log line", f"{self._name}: first at line {number}")

    def close(self) -> None:
        self._handle.close()


def _frame_of(msg: Any) -> CanFrame:
    data = bytes(msg.data or b"")
    return CanFrame(
        id=int(msg.arbitration_id),
        is_extended=bool(msg.is_extended_id),
        is_rtr=bool(msg.is_remote_frame),
        is_error=bool(msg.is_error_frame),
        dlc=int(msg.dlc),
        data=data,
    )


class CanLogRecording(ClosingRecording):
    """A CAN log file as a :class:`~superlane_tools.recording.base.Recording`.

    Each CAN channel (``can0``, ``vcan1``, ASC channel numbers) is one topic of type
    ``can_msgs/msg/Frame``; a log without channel names has the single topic ``can``. Messages
    come in file order with ``log_time_ns`` from the log's timestamps (rounded to whole
    microseconds, the resolution of candump and ASC) and ``stamp_ns=None``. Timestamp
    discontinuities are kept as they are. Malformed candump lines are skipped and counted in
    :attr:`skipped`; a reader error in an ASC or BLF file ends the stream there (reported).

    Args:
        path: The ``.log``, ``.asc`` or ``.blf`` file.

    Raises:
        RecordingError: If the file does not look like a CAN log.
    """

    def __init__(self, path: str | os.PathLike[str]) -> None:
        self.path = Path(path)
        if not looks_like_canlog(self.path):
            raise RecordingError(f"{self.path}: not a CAN log (.log candump, .asc or .blf)")
        self._skips = SkipLog()
        self._topics: dict[str, int] | None = None

    @property
    def skipped(self) -> list[Skipped]:
        """What was skipped so far: malformed lines, unreadable file tails."""
        return self._skips.items()

    def _frames(self) -> Iterator[tuple[str, int, CanFrame]]:
        import can

        self._skips.clear()
        lines: _CheckedLines | None = None
        try:
            if self.path.suffix.lower() == ".log":
                lines = _CheckedLines(self.path, self._skips)
                reader: Any = can.CanutilsLogReader(file=lines)  # type: ignore[arg-type]
            else:
                reader = can.LogReader(self.path)
        except (OSError, ValueError) as err:
            raise RecordingError(f"{self.path}: cannot read CAN log: {err}") from err
        try:
            iterator = iter(reader)
            while True:
                try:
                    msg = next(iterator)
                except StopIteration:
                    break
                except (ValueError, OSError, struct.error, IndexError, KeyError) as err:
                    self._skips.add("unreadable CAN log tail", f"{self.path.name}: {err}")
                    break
                channel = msg.channel
                topic = DEFAULT_TOPIC if channel in (None, "") else str(channel)
                yield topic, round(float(msg.timestamp) * 1e6) * 1000, _frame_of(msg)
        finally:
            if lines is not None:
                lines.close()
            stop = getattr(reader, "stop", None)
            if callable(stop):
                stop()

    def topics(self) -> list[TopicInfo]:
        """Return one topic per CAN channel with its frame count (needs one pass)."""
        if self._topics is None:
            counts: dict[str, int] = {}
            for topic, _, _ in self._frames():
                counts[topic] = counts.get(topic, 0) + 1
            self._topics = counts
        return [
            TopicInfo(topic, CAN_FRAME_TYPE, "can", count)
            for topic, count in sorted(self._topics.items())
        ]

    def messages(
        self,
        topics: Collection[str] | None = None,
        start_ns: int | None = None,
        stop_ns: int | None = None,
    ) -> Iterator[Message]:
        """Yield CAN frames as messages (``data`` is a :class:`CanFrame`) in file order."""
        for topic, log_time_ns, frame in self._frames():
            if topics is not None and topic not in topics:
                continue
            if in_range(log_time_ns, start_ns, stop_ns):
                yield Message(topic, log_time_ns, None, CAN_FRAME_TYPE, frame)

    def raw_messages(
        self,
        topics: Collection[str] | None = None,
        start_ns: int | None = None,
        stop_ns: int | None = None,
    ) -> Iterator[RawMessage]:
        """Yield frames serialized with :func:`encode_raw_frame` (encoding ``can``)."""
        for msg in self.messages(topics, start_ns, stop_ns):
            yield RawMessage(
                msg.topic, msg.log_time_ns, CAN_FRAME_TYPE, "can", encode_raw_frame(msg.data)
            )

    def close(self) -> None:
        """Nothing stays open between iterations; present for the protocol."""
