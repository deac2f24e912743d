"""Recover an unindexed or damaged ROS 1 bag by scanning its records, like ``rosbag reindex``.

A recorder that crashed leaves a ``.bag.active`` file without the index at its end; a copy cut
short loses the index too. rosbags refuses such files. This reader walks the records from the
start instead: connection records define the topics, chunks (uncompressed, bz2 or lz4) hold the
messages. A chunk cut short or damaged yields the messages before the damage; the scan stops at
the first record it cannot read. :func:`scan_ros1_file` returns the walk as a
:class:`~superlane_tools.recording.scan.RecordingScan`; :class:`Ros1ScanReader` offers it through
the part of the rosbags reader interface that
:class:`~superlane_tools.recording.rosbag_source.RosbagRecording` uses.
"""

from __future__ import annotations

import bz2
import struct
from collections.abc import Collection, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from types import TracebackType
from typing import Any, Self

from rosbags.interfaces import (
    Connection,
    ConnectionExtRosbag1,
    MessageDefinition,
    MessageDefinitionFormat,
)

from superlane_tools.recording._scan_types import (
    Loss,
    RecordingScan,
    ScanChannel,
    ScanSchema,
    chunk_loss,
)
from superlane_tools.recording.base import SkipLog, in_range, ros2_msgtype
from superlane_tools.recording.errors import RecordingError
from superlane_tools.recording.formats.ros1 import MAGIC

_U32 = struct.Struct("<I")
_OP_MSG, _OP_BAG_HEADER, _OP_INDEX, _OP_CHUNK, _OP_CONNECTION = 0x02, 0x03, 0x04, 0x05, 0x07
_INDEX_ENTRY = struct.Struct("<III")  # time sec, time nsec, offset in the chunk
_MAX_RECORD = 1 << 31


def _fields(header: bytes) -> dict[str, bytes]:
    """Parse a record header (``len name=value`` fields)."""
    out: dict[str, bytes] = {}
    pos = 0
    while pos + 4 <= len(header):
        (size,) = _U32.unpack_from(header, pos)
        pos += 4
        if size > len(header) - pos:
            raise ValueError("header field runs past the header")
        name, sep, value = header[pos : pos + size].partition(b"=")
        if not sep:
            raise ValueError("header field without '='")
        out[name.decode("ascii", "replace")] = value
        pos += size
    return out


def _records(data: bytes, pos: int = 0) -> Iterator[tuple[dict[str, bytes], bytes, int, int]]:
    """Yield ``(header fields, data, offset, next offset)`` of each complete record.

    Stops at the first record that is cut short or garbled.
    """
    end = len(data)
    while pos + 8 <= end:
        (hlen,) = _U32.unpack_from(data, pos)
        if hlen > end - pos - 8:
            return
        try:
            header = _fields(data[pos + 4 : pos + 4 + hlen])
        except ValueError:
            return
        dpos = pos + 4 + hlen
        (dlen,) = _U32.unpack_from(data, dpos)
        if dlen > end - dpos - 4:
            return
        yield header, data[dpos + 4 : dpos + 4 + dlen], pos, dpos + 4 + dlen
        pos = dpos + 4 + dlen


def _inflate(compression: str, payload: bytes) -> tuple[bytes, bool]:
    """Decompress a chunk as far as it is intact; return (data, complete)."""
    if compression == "none":
        return payload, True
    if compression == "bz2":
        inflater = bz2.BZ2Decompressor()
        try:
            out = inflater.decompress(payload)
        except (OSError, ValueError, EOFError):
            return b"", False
        return out, inflater.eof
    if compression == "lz4":
        try:
            import lz4.frame  # type: ignore[import-untyped]
        except ImportError:
            return b"", False
        try:
            return lz4.frame.decompress(payload), True
        except RuntimeError:
            return b"", False
    return b"", False


@dataclass
class _LostChunk:
    """A damaged chunk, completed by the index data records written after it."""

    offset: int
    stop: int
    detail: str
    recovered: dict[int, int]  # connection id -> messages read before the damage
    times: dict[int, list[int]] = field(default_factory=dict)  # connection id -> lost times


@dataclass
class Ros1Walk:
    """Everything a walk of a ROS 1 bag found (see :func:`walk_ros1`)."""

    path: Path
    conns: dict[int, dict[str, bytes]] = field(default_factory=dict)
    messages: list[tuple[int, int, bytes]] = field(default_factory=list)
    """``(log time ns, connection id, payload)`` in file order."""
    counts: dict[int, int] = field(default_factory=dict)
    losses: list[Loss] = field(default_factory=list)
    index_pos: int = 0
    """Where the bag header says the index section starts (0: never written)."""
    _lost_chunks: list[_LostChunk] = field(default_factory=list)

    def stored_messages(
        self, channel_ids: Collection[int]
    ) -> Iterator[tuple[int, int, int, bytes]]:
        """Yield ``(connection id, log time, log time, payload)`` in file order."""
        for t, cid, body in self.messages:
            if cid in channel_ids:
                yield cid, t, t, body

    def text(self, cid: int, key: str) -> str:
        """Return a connection header field as text (empty when absent)."""
        return self.conns[cid].get(key, b"").decode("utf-8", "replace")

    def scan_channel(self, cid: int) -> ScanChannel:
        """Return connection ``cid`` in the form of :mod:`~superlane_tools.recording.scan`."""
        stored_type = self.text(cid, "type")
        meta: dict[str, str] = {
            key: self.text(cid, key)
            for key in ("md5sum", "callerid", "latching")
            if key in self.conns[cid]
        }
        return ScanChannel(
            cid,
            self.text(cid, "topic"),
            ros2_msgtype(stored_type),
            "ros1",
            ScanSchema(stored_type, "ros1msg", self.conns[cid].get("message_definition", b"")),
            meta,
        )

    def _finish_chunk_losses(self) -> None:
        for lost in self._lost_chunks:
            by_topic: dict[str, list[int]] = {}
            for cid, times in sorted(lost.times.items()):
                topic = self.text(cid, "topic") if cid in self.conns else f"connection {cid}"
                by_topic.setdefault(topic, []).extend(times)
            self.losses.append(chunk_loss(lost.detail, (lost.offset, lost.stop), by_topic))
        self.losses.sort(key=lambda loss: loss.byte_start)


def walk_ros1(path: Path, data: bytes) -> Ros1Walk:
    """Walk the records of a ROS 1 bag's bytes (see the module docstring).

    Raises:
        ValueError: If ``data`` does not start with the ROS 1 bag magic.
    """
    if not data.startswith(MAGIC):
        raise ValueError("no ROS 1 bag magic")
    walk = Ros1Walk(path)
    name = path.name
    last = len(MAGIC)
    pending: _LostChunk | None = None
    for header, body, offset, after in _records(data, last):
        last = after
        op = header.get("op", b"\x00")[:1]
        if op == bytes([_OP_INDEX]):
            if pending is not None:
                _index_data(header, body, pending)
            continue
        pending = None
        if op == bytes([_OP_CONNECTION]):
            _connection_record(walk, header, body)
        elif op == bytes([_OP_CHUNK]):
            compression = header.get("compression", b"none").decode("ascii", "replace")
            inner, complete = _inflate(compression, body)
            before = dict(walk.counts)
            if not _chunk(walk, inner) or not complete:
                recovered = {c: n - before.get(c, 0) for c, n in walk.counts.items()}
                detail = f"{name}: chunk at byte {offset}: later messages lost"
                pending = _LostChunk(offset, after, detail, recovered)
                walk._lost_chunks.append(pending)
        elif op == bytes([_OP_MSG]):
            _message(walk, header, body)
        elif op == bytes([_OP_BAG_HEADER]) and len(header.get("index_pos", b"")) == 8:
            (walk.index_pos,) = struct.unpack("<Q", header["index_pos"])
    walk._finish_chunk_losses()
    tail = data[last:]
    if len(tail) > 8:  # a chunk cut short: keep its complete messages
        latest = max((t for t, _, _ in walk.messages), default=None)
        cut = _cut_chunk(walk, tail)
        walk.losses.append(
            Loss(
                "truncated file",
                f"{name}: unreadable from byte {last}; "
                f"{cut} messages recovered from the cut record, later ones are lost",
                last,
                len(data),
                start_ns=latest,
            )
        )
    return walk


def _index_data(header: dict[str, bytes], body: bytes, lost: _LostChunk) -> None:
    """Note the messages an index data record lists beyond those read from a damaged chunk."""
    try:
        (cid,) = _U32.unpack(header["conn"])
    except (KeyError, struct.error):
        return
    times = [
        sec * 1_000_000_000 + nsec
        for sec, nsec, _ in (
            _INDEX_ENTRY.unpack_from(body, pos)
            for pos in range(0, len(body) - _INDEX_ENTRY.size + 1, _INDEX_ENTRY.size)
        )
    ]
    missing = times[lost.recovered.get(cid, 0) :]
    if missing:
        lost.times[cid] = missing


def _cut_chunk(walk: Ros1Walk, tail: bytes) -> int:
    """Recover the complete messages at the start of a chunk record cut short."""
    (hlen,) = _U32.unpack_from(tail, 0)
    if hlen > len(tail) - 8:
        return 0
    try:
        header = _fields(tail[4 : 4 + hlen])
    except ValueError:
        return 0
    if header.get("op", b"")[:1] != bytes([_OP_CHUNK]):
        return 0
    compression = header.get("compression", b"none").decode("ascii", "replace")
    payload = tail[8 + hlen :]
    if compression == "bz2":
        try:
            inner = bz2.BZ2Decompressor().decompress(payload)
        except (OSError, ValueError, EOFError):
            inner = b""
    else:
        inner = payload if compression == "none" else b""
    before = len(walk.messages)
    _chunk(walk, inner)
    return len(walk.messages) - before


def _chunk(walk: Ros1Walk, inner: bytes) -> bool:
    """Read a chunk's records; return False when damage stopped it before its end."""
    end = 0
    for header, body, _, after in _records(inner):
        end = after
        op = header.get("op", b"\x00")[:1]
        if op == bytes([_OP_CONNECTION]):
            _connection_record(walk, header, body)
        elif op == bytes([_OP_MSG]):
            _message(walk, header, body)
    return end == len(inner)


def _connection_record(walk: Ros1Walk, header: dict[str, bytes], body: bytes) -> None:
    try:
        (cid,) = _U32.unpack(header["conn"])
        fields = _fields(body)
    except (KeyError, struct.error, ValueError):
        return
    fields.setdefault("topic", header.get("topic", b""))
    walk.conns.setdefault(cid, fields)


def _message(walk: Ros1Walk, header: dict[str, bytes], body: bytes) -> None:
    try:
        (cid,) = _U32.unpack(header["conn"])
        sec, nsec = struct.unpack("<II", header["time"])
    except (KeyError, struct.error):
        return
    walk.messages.append((sec * 1_000_000_000 + nsec, cid, body))
    walk.counts[cid] = walk.counts.get(cid, 0) + 1


def _read_walk(path: Path) -> Ros1Walk:
    return walk_ros1(path, path.read_bytes())


def scan_ros1_file(path: Path) -> RecordingScan:
    """Scan ``path`` (see :func:`superlane_tools.recording.scan.scan_ros1`)."""
    try:
        walk = _read_walk(path)
    except OSError as err:
        raise RecordingError(f"cannot read {path}: {err.strerror}") from err
    except ValueError as err:
        raise RecordingError(f"{path} is not a recording: {err}") from err
    size = path.stat().st_size
    return RecordingScan(
        path=path,
        format="ros1",
        channels={cid: walk.scan_channel(cid) for cid in sorted(walk.conns)},
        message_counts=dict(walk.counts),
        losses=tuple(walk.losses),
        complete=0 < walk.index_pos < size and not walk.losses,
        _walk=walk,
    )


class Ros1ScanReader:
    """Reads a ROS 1 bag without its index (see the module docstring).

    Args:
        path: The ``.bag`` or ``.bag.active`` file.
        skips: Where damage is reported.
    """

    def __init__(self, path: Path, skips: SkipLog) -> None:
        self.path = path
        walk = _read_walk(path)
        for loss in walk.losses:
            skips.add(loss.what, loss.detail, 0)
        self._walk = walk
        self._messages = sorted(walk.messages, key=lambda item: item[0])
        self.connections = [self._connection(cid) for cid in sorted(walk.conns)]

    def _connection(self, cid: int) -> Connection:
        walk = self._walk
        latching = walk.conns[cid].get("latching")
        return Connection(
            id=cid,
            topic=walk.text(cid, "topic"),
            msgtype=ros2_msgtype(walk.text(cid, "type")),
            msgdef=MessageDefinition(
                MessageDefinitionFormat.MSG, walk.text(cid, "message_definition")
            ),
            digest=walk.text(cid, "md5sum"),
            msgcount=walk.counts.get(cid, 0),
            ext=ConnectionExtRosbag1(
                callerid=walk.text(cid, "callerid") or None,
                latching=int(latching) if latching and latching.isdigit() else None,
            ),
            owner=self,
        )

    def messages(
        self,
        connections: Collection[Connection] = (),
        start: int | None = None,
        stop: int | None = None,
    ) -> Iterator[tuple[Connection, int, bytes]]:
        """Yield ``(connection, log time, data)`` in log-time order, ``[start, stop)``."""
        by_id = {c.id: c for c in (connections or self.connections)}
        for t, cid, body in self._messages:
            conn = by_id.get(cid)
            if conn is None or not in_range(t, start, stop):
                continue
            yield conn, t, body

    def __enter__(self) -> Self:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        return None

    def close(self) -> None:
        """Nothing stays open."""


def scan_reader(path: Path, skips: SkipLog) -> Any:
    """Return a :class:`Ros1ScanReader` over ``path`` (loads the recovered messages)."""
    return Ros1ScanReader(path, skips)
