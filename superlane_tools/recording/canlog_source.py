"""CAN log files (candump ``-l`` ``.log``, Vector ``.asc``, ``.blf``) as a streaming recording."""

from __future__ import annotations

import math
import os
import re
import struct
import zlib
from collections.abc import Collection, Generator, Hashable, Iterator
from pathlib import Path
from typing import Any, NamedTuple

from superlane_tools.recording.base import SkipLog, in_range, storable_time
from superlane_tools.recording.decoding import Decode, RawSource
from superlane_tools.recording.errors import RecordingError
from superlane_tools.recording.formats.canlog import (
    ASC_SUFFIX,
    BLF_MAGIC,
    BLF_SUFFIX,
    CANDUMP_SUFFIX,
    SUFFIXES,
)
from superlane_tools.records import RawMessage, Skipped, TopicInfo

CAN_FRAME_TYPE = "can_msgs/msg/Frame"
CANLOG_SUFFIXES = SUFFIXES
DEFAULT_TOPIC = "can"

_RAW_HEADER = struct.Struct(">IB")
_EXTENDED_FLAG = 0x80000000
# Up to 64 data bytes (CAN FD): a longer payload is a damaged line, not a frame.
_CANDUMP_LINE = re.compile(
    r"^\s*\(\d{1,12}(?:\.\d{1,9})?\)\s+\S{1,64}\s+[0-9A-Fa-f]{1,8}#"
    r"(?:#[0-9A-Fa-f])?(?:(?:[0-9A-Fa-f]{2}){0,64}|[Rr]\d?)(?:\s+[RrTt])?\s*$"
)
_CANDUMP_START = re.compile(r"(?=\(\d)")
SNIFF_BYTES = 65536
"""How much of a text log is looked at to recognise its format."""
SNIFF_LINES = 200
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


def decode_raw_frame(payload: bytes) -> CanFrame:
    """Parse a frame serialized with :func:`encode_raw_frame`.

    Raises:
        ValueError: If the payload is shorter than its 5-byte header.
    """
    if len(payload) < _RAW_HEADER.size:
        raise ValueError(f"a raw CAN frame needs {_RAW_HEADER.size} header bytes")
    flags, dlc = _RAW_HEADER.unpack_from(payload)
    return CanFrame(
        id=flags & 0x1FFFFFFF,
        is_extended=bool(flags & _EXTENDED_FLAG),
        is_rtr=bool(flags & 0x40000000),
        is_error=bool(flags & 0x20000000),
        dlc=dlc,
        data=bytes(payload[_RAW_HEADER.size :]),
    )


def decode_raw_message(raw: RawMessage) -> CanFrame:
    """Decode a raw message of a CAN log (the source's decoder, see :func:`decode_raw_frame`)."""
    return decode_raw_frame(raw.payload)


def looks_like_canlog(path: str | os.PathLike[str]) -> bool:
    """Return True when ``path`` is a CAN log python-can reads (by suffix and first bytes)."""
    src = Path(path)
    suffix = src.suffix.lower()
    if not src.is_file() or suffix not in CANLOG_SUFFIXES:
        return False
    try:
        with src.open("rb") as handle:
            head = handle.read(SNIFF_BYTES)
    except OSError:
        return False
    if suffix == BLF_SUFFIX:
        return head.startswith(BLF_MAGIC)
    if suffix == ASC_SUFFIX:
        return any(_ASC_START.match(line) for line in head.splitlines()[:20])
    return candump_lines(path) > 0


def candump_lines(path: str | os.PathLike[str]) -> int:
    """Count well-formed candump lines among the first lines of ``path`` (0: not candump).

    Looks at up to :data:`SNIFF_LINES` lines of the first :data:`SNIFF_BYTES`, so a comment
    header, a garbled or binary first line or stray NUL bytes do not hide the frames after them.
    """
    try:
        with Path(path).open("rb") as handle:
            head = handle.read(SNIFF_BYTES)
    except OSError:
        return 0
    lines = head.splitlines()[:SNIFF_LINES]
    return sum(1 for line in lines if _CANDUMP_LINE.match(line.decode("ascii", "replace")))


class _CheckedLines:
    """A text file that hands python-can only well-formed lines; counts the rest.

    candump logs pass only lines that match the candump format. ASC logs pass every line
    without damage (bytes that are not ASCII, control characters); python-can ignores the
    header and event lines it does not know.
    """

    def __init__(self, path: Path, skips: SkipLog, candump: bool = True) -> None:
        self._handle = path.open("r", encoding="ascii", errors="replace", newline=None)
        self._skips = skips
        self._name = path.name
        self._candump = candump

    def __iter__(self) -> Iterator[str]:
        for number, line in enumerate(self._handle, start=1):
            # candump: cut before every "(<digit>", so frames run together by binary junk (a
            # NUL where the line break was) are each read or each counted
            pieces = _CANDUMP_START.split(line.rstrip("\r\n")) if self._candump else [line]
            for piece in pieces:
                if not piece.strip():
                    continue
                if self._candump:
                    ok = bool(_CANDUMP_LINE.match(piece))
                else:
                    ok = piece.rstrip("\r\n").replace("\t", " ").isprintable()
                    ok = ok and "\ufffd" not in piece and len(piece) < 4096
                if ok:
                    yield piece if not self._candump else piece + "\n"
                elif not piece.lstrip().startswith(("#", "//")):
                    self._skips.add("bad CAN log line", f"{self._name}: first at line {number}")

    def close(self) -> None:
        self._handle.close()


_BLF_OBJ = struct.Struct("<4sHHII")  # LOBJ signature, header size, version, object size, type
_BLF_CONTAINER = 10
_BLF_MAX_OBJECT = 1 << 26


def robust_blf_reader(path: Path, skips: SkipLog) -> Any:
    """Return python-can's BLF reader made to survive damage, reporting it in ``skips``.

    python-can stops the whole log at the first garbled object or container (zlib errors
    escape) and says nothing about a file cut short. This reader resynchronises on the next
    ``LOBJ`` signature after garbled bytes, skips a container that does not decompress (only
    the frames in it are lost), and reports a file shorter than its header says.
    """
    import can

    class _Reader(can.BLFReader):
        _lost = False
        """True after a damaged container: an object spanning from it is gone."""

        def __iter__(self) -> Generator[Any, None, None]:
            return _blf_frames(self, path, skips)

    return _Reader(path)


def _blf_frames(reader: Any, path: Path, skips: SkipLog) -> Generator[Any, None, None]:
    """Yield the frames of ``reader``'s objects (:func:`robust_blf_reader`), then close it."""
    name = path.name
    size = path.stat().st_size
    if reader.file_size and size < reader.file_size:
        skips.add("truncated file", f"{name}: {size} of {reader.file_size} bytes", 0)
    while True:
        start = reader.file.tell()
        data = reader.file.read(_BLF_OBJ.size)
        if len(data) < _BLF_OBJ.size:
            if data.strip(b"\0"):
                skips.add("truncated file", f"{name}: cut inside an object", 0)
            break
        signature, _, _, obj_size, obj_type = _BLF_OBJ.unpack(data)
        if signature != b"LOBJ" or not _BLF_OBJ.size <= obj_size <= _BLF_MAX_OBJECT:
            skips.add("garbled BLF bytes", f"{name}: first at byte {start}", 0)
            if not _resync(reader.file, start + 1):
                break
            continue
        obj_data = reader.file.read(obj_size - _BLF_OBJ.size)
        cut = len(obj_data) < obj_size - _BLF_OBJ.size
        if cut:
            skips.add("truncated file", f"{name}: cut inside the object at byte {start}", 0)
        reader.file.read(obj_size % 4)
        if obj_type == _BLF_CONTAINER:
            yield from _container_frames(
                reader, obj_data, f"{name}: container at byte {start}", skips
            )
        if cut:
            break
    reader.stop()


def _container_frames(
    reader: Any, obj_data: bytes, where: str, skips: SkipLog
) -> Generator[Any, None, None]:
    """Yield a container's frames: all of an intact one, those before the damage else."""
    import can

    error: str | None = None
    try:
        method, _ = struct.unpack_from("<H6xI", obj_data)
    except struct.error:
        method, error = 0, "container header cut short"
    payload = obj_data[16:]
    if method == 2:
        payload, error = _inflate_prefix(payload)
    elif method != 0:
        payload, error = b"", f"unknown compression method {method}"
    data = reader._tail + payload
    reader._tail = b""
    if reader._lost:  # an object spanning from a damaged container is gone: resync
        found = data.find(b"LOBJ")
        data = data[found:] if found >= 0 else b""
    reader._lost = False
    while data:
        bad = _first_bad_object(data)
        try:
            yield from reader._parse_container(data if bad is None else data[:bad])
            if bad is None:
                break
            skips.add("garbled BLF object", f"{where}: object of a bad size")
            resume = bad
        except (ValueError, struct.error, IndexError, can.io.blf.BLFParseError) as err:
            skips.add("garbled BLF object", f"{where}: {type(err).__name__}: {err}")
            resume = reader._pos
        found = data.find(b"LOBJ", resume + 1)
        data = data[found:] if found >= 0 else b""
        reader._tail = b""
    if error is not None:
        skips.add("corrupt BLF container", f"{where}: {error}; later frames in it lost")
        reader._tail = b""
        reader._lost = True


def _resync(file: Any, offset: int) -> bool:
    """Seek ``file`` to the next ``LOBJ`` at or after ``offset``; False at the end of the file."""
    file.seek(offset)
    carry = b""
    base = offset
    while True:
        block = file.read(1 << 16)
        if not block:
            return False
        hay = carry + block
        found = hay.find(b"LOBJ")
        if found >= 0:
            file.seek(base - len(carry) + found)
            return True
        carry = hay[-3:]
        base += len(block)


def _first_bad_object(data: bytes) -> int | None:
    """Return the offset of the first object with an impossible size, or None.

    python-can loops forever on an object of size zero; such an object is damage.
    """
    pos, end = 0, len(data)
    while pos + _BLF_OBJ.size <= end:
        found = data.find(b"LOBJ", pos, pos + 8)
        if found < 0:
            return None  # python-can reports the garbled bytes itself
        obj_size = _BLF_OBJ.unpack_from(data, found)[3]
        if obj_size < _BLF_OBJ.size:
            return found
        pos = found + obj_size
    return None


def _inflate_prefix(data: bytes, step: int = 1024) -> tuple[bytes, str | None]:
    """Decompress zlib ``data`` as far as it is intact: (output, None) or (prefix, error)."""
    inflater = zlib.decompressobj()
    parts: list[bytes] = []
    for pos in range(0, len(data), step):
        try:
            parts.append(inflater.decompress(data[pos : pos + step]))
        except zlib.error as err:
            return b"".join(parts), f"zlib: {err}"
        if inflater.eof:
            break
    if not inflater.eof:
        return b"".join(parts), "compressed data cut short"
    return b"".join(parts), None


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


class CanLogRecording(RawSource):
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
        suffix = self.path.suffix.lower()
        try:
            if suffix in {CANDUMP_SUFFIX, ASC_SUFFIX}:
                lines = _CheckedLines(self.path, self._skips, candump=suffix == CANDUMP_SUFFIX)
                cls = can.CanutilsLogReader if suffix == CANDUMP_SUFFIX else can.ASCReader
                reader: Any = cls(file=lines)  # type: ignore[arg-type]
            else:
                reader = robust_blf_reader(self.path, self._skips)
        except (OSError, ValueError, struct.error) as err:
            raise RecordingError(f"{self.path}: cannot read CAN log: {err}") from err
        try:
            iterator = iter(reader)
            while True:
                try:
                    msg = next(iterator)
                except StopIteration:
                    break
                except Exception as err:  # python-can parse errors: keep what came before
                    self._skips.add(
                        "unreadable CAN log tail", f"{self.path.name}: {type(err).__name__}: {err}"
                    )
                    break
                channel = msg.channel
                topic = DEFAULT_TOPIC if channel in (None, "") else str(channel)
                seconds = float(msg.timestamp)
                t_ns = round(seconds * 1e6) * 1000 if math.isfinite(seconds) else -1
                if not storable_time(t_ns):
                    self._skips.add("log time beyond int64 ns", f"{topic}: {seconds!r} s")
                    continue
                yield topic, t_ns, _frame_of(msg)
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

    def _pass_skips(self) -> SkipLog:
        return self._skips

    def _keyed_raw(
        self, topics: Collection[str] | None, start_ns: int | None, stop_ns: int | None
    ) -> Iterator[tuple[Hashable, RawMessage]]:
        """Yield frames serialized with :func:`encode_raw_frame` (encoding ``can``), one key."""
        for topic, log_time_ns, frame in self._frames():
            if topics is not None and topic not in topics:
                continue
            if in_range(log_time_ns, start_ns, stop_ns):
                raw = RawMessage(topic, log_time_ns, CAN_FRAME_TYPE, "can", encode_raw_frame(frame))
                yield None, raw

    def _decoder_for(self, key: Hashable, raw: RawMessage) -> Decode:
        """Return :func:`decode_raw_message`: messages are :class:`CanFrame` objects."""
        del key, raw
        return decode_raw_message

    def close(self) -> None:
        """Nothing stays open between iterations; present for the protocol."""
