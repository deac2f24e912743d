"""Recover an unindexed or damaged ROS 1 bag by scanning its records, like ``rosbag reindex``.

A recorder that crashed leaves a ``.bag.active`` file without the index at its end; a copy cut
short loses the index too. rosbags refuses such files. This reader walks the records from the
start instead: connection records define the topics, chunks (uncompressed, bz2 or lz4) hold the
messages. A chunk cut short or damaged yields the messages before the damage; the scan stops at
the first record it cannot read. It offers the part of the rosbags reader interface that
:class:`~superlane_tools.recording.rosbag_source.RosbagRecording` uses.
"""

from __future__ import annotations

import bz2
import struct
from collections.abc import Collection, Iterator
from pathlib import Path
from types import TracebackType
from typing import Any, Self

from rosbags.interfaces import (
    Connection,
    ConnectionExtRosbag1,
    MessageDefinition,
    MessageDefinitionFormat,
)

from superlane_tools.recording.base import SkipLog, in_range, ros2_msgtype

MAGIC = b"#ROSBAG V2.0\n"
_U32 = struct.Struct("<I")
_OP_MSG, _OP_BAG_HEADER, _OP_CHUNK, _OP_CONNECTION = 0x02, 0x03, 0x05, 0x07
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


class Ros1ScanReader:
    """Reads a ROS 1 bag without its index (see the module docstring).

    Args:
        path: The ``.bag`` or ``.bag.active`` file.
        skips: Where damage is reported.
    """

    def __init__(self, path: Path, skips: SkipLog) -> None:
        self.path = path
        self._skips = skips
        self._messages: list[tuple[int, int, bytes]] = []  # (log time, connection id, data)
        self._conns: dict[int, dict[str, bytes]] = {}
        self._counts: dict[int, int] = {}
        self._scan(path.read_bytes())
        self.connections = [self._connection(cid) for cid in sorted(self._conns)]

    def _scan(self, data: bytes) -> None:
        if not data.startswith(MAGIC):
            raise ValueError("no ROS 1 bag magic")
        name = self.path.name
        pos = len(MAGIC)
        last = pos
        for header, body, offset, after in _records(data, pos):
            last = after
            op = header.get("op", b"\x00")[:1]
            if op == bytes([_OP_CONNECTION]):
                self._connection_record(header, body)
            elif op == bytes([_OP_CHUNK]):
                compression = header.get("compression", b"none").decode("ascii", "replace")
                inner, complete = _inflate(compression, body)
                if not self._chunk(inner) or not complete:
                    self._skips.add(
                        "corrupt chunk", f"{name}: chunk at byte {offset}: later messages lost", 0
                    )
            elif op == bytes([_OP_MSG]):
                self._message(header, body)
        tail = data[last:]
        if len(tail) > 8:  # a chunk cut short: keep its complete messages
            cut = self._cut_chunk(tail)
            self._skips.add(
                "truncated file",
                f"{name}: unreadable from byte {last}; "
                f"{cut} messages recovered from the cut record, later ones are lost",
                0,
            )
        self._messages.sort(key=lambda item: item[0])

    def _cut_chunk(self, tail: bytes) -> int:
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
        before = len(self._messages)
        self._chunk(inner)
        return len(self._messages) - before

    def _chunk(self, inner: bytes) -> bool:
        """Read a chunk's records; return False when damage stopped it before its end."""
        end = 0
        for header, body, _, after in _records(inner):
            end = after
            op = header.get("op", b"\x00")[:1]
            if op == bytes([_OP_CONNECTION]):
                self._connection_record(header, body)
            elif op == bytes([_OP_MSG]):
                self._message(header, body)
        return end == len(inner)

    def _connection_record(self, header: dict[str, bytes], body: bytes) -> None:
        try:
            (cid,) = _U32.unpack(header["conn"])
            fields = _fields(body)
        except (KeyError, struct.error, ValueError):
            return
        fields.setdefault("topic", header.get("topic", b""))
        self._conns.setdefault(cid, fields)

    def _message(self, header: dict[str, bytes], body: bytes) -> None:
        try:
            (cid,) = _U32.unpack(header["conn"])
            sec, nsec = struct.unpack("<II", header["time"])
        except (KeyError, struct.error):
            return
        self._messages.append((sec * 1_000_000_000 + nsec, cid, body))
        self._counts[cid] = self._counts.get(cid, 0) + 1

    def _connection(self, cid: int) -> Connection:
        fields = self._conns[cid]

        def text(key: str) -> str:
            return fields.get(key, b"").decode("utf-8", "replace")

        latching = fields.get("latching")
        return Connection(
            id=cid,
            topic=text("topic"),
            msgtype=ros2_msgtype(text("type")),
            msgdef=MessageDefinition(MessageDefinitionFormat.MSG, text("message_definition")),
            digest=text("md5sum"),
            msgcount=self._counts.get(cid, 0),
            ext=ConnectionExtRosbag1(
                callerid=text("callerid") or None,
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
