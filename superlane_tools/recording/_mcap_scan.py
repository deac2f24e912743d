"""The MCAP record walk behind :mod:`~superlane_tools.recording.scan` and the MCAP source.

Checks a file's summary (footer CRC, chunk indexes) and, when it cannot be used, walks the data
section record by record: schemas, channels, chunk positions and message counts of everything
readable, and a :class:`~superlane_tools.recording.scan.Loss` for each damaged region.
"""

from __future__ import annotations

import io
import struct
import zlib
from collections.abc import Collection, Iterator
from dataclasses import dataclass, field
from enum import Enum
from pathlib import Path
from typing import TYPE_CHECKING, Any, BinaryIO, NamedTuple

from superlane_tools.recording._mcap_decode import msgtype_name
from superlane_tools.recording._scan_types import (
    Loss,
    RecordingScan,
    ScanChannel,
    ScanSchema,
    chunk_loss,
)
from superlane_tools.recording.errors import RecordingError
from superlane_tools.recording.formats.mcap import MAGIC as MCAP_MAGIC

if TYPE_CHECKING:
    from mcap.records import Channel, Chunk, ChunkIndex, Schema
    from mcap.records import Message as McapMessage
    from mcap.summary import Summary


RECORD_PREFIX = 9  # opcode (1 byte) + record length (8 bytes)
_FOOTER_SIZE = RECORD_PREFIX + 8 + 8 + 4  # summary start, summary offset start, summary CRC
_FOOTER_OPCODE = 0x02
_CHUNK_OPCODE = 0x06


class ChunkRef(NamedTuple):
    """Where one chunk lies and which log times and channels it holds."""

    offset: int
    start_ns: int
    end_ns: int
    channel_ids: frozenset[int] | None  # None: unknown without reading the chunk


def closing_magic_present(handle: BinaryIO) -> bool:
    """Return True when the file ends with the MCAP magic (it was finished)."""
    handle.seek(-len(MCAP_MAGIC), io.SEEK_END)
    return handle.read(len(MCAP_MAGIC)) == MCAP_MAGIC


def summary_problem(handle: BinaryIO) -> str | None:
    """Check the footer's summary CRC; return what is wrong, or None (also when unset)."""
    size = handle.seek(0, io.SEEK_END)
    footer_at = size - len(MCAP_MAGIC) - _FOOTER_SIZE
    if footer_at < len(MCAP_MAGIC):
        return "file too short for a footer"
    handle.seek(footer_at)
    footer = handle.read(_FOOTER_SIZE)
    if footer[0] != _FOOTER_OPCODE:
        return "no footer record before the closing magic"
    summary_start, _, crc = struct.unpack_from("<QQI", footer, RECORD_PREFIX)
    if summary_start == 0 or crc == 0:
        return None
    if not len(MCAP_MAGIC) <= summary_start <= footer_at:
        return f"summary offset {summary_start} outside the file"
    handle.seek(summary_start)
    covered = handle.read(footer_at + _FOOTER_SIZE - 4 - summary_start)
    if zlib.crc32(covered) != crc:
        return "summary CRC mismatch"
    return None


def index_problem(handle: BinaryIO, summary: Summary) -> str | None:
    """Check that every chunk index points at a chunk record (a summary without a CRC)."""
    for ci in summary.chunk_indexes:
        handle.seek(ci.chunk_start_offset)
        if handle.read(1) != bytes([_CHUNK_OPCODE]):
            return f"chunk index points at byte {ci.chunk_start_offset}, not at a chunk"
        if ci.message_start_time > ci.message_end_time:
            return f"chunk index at byte {ci.chunk_start_offset} has reversed times"
    for cid, channel in summary.channels.items():
        if channel.schema_id and channel.schema_id not in summary.schemas:
            return f"channel {cid} ({channel.topic}) names a missing schema"
    return None


def read_summary(handle: BinaryIO) -> tuple[Summary | None, str | None, bool]:
    """Read a finished file's summary.

    Returns:
        ``(summary, problem, complete)``: the summary when it is intact (else None), what is
        wrong with it (None when fine or when the file was never finished), and whether the
        file ends with the closing magic.
    """
    from mcap.reader import SeekingReader

    complete = closing_magic_present(handle)
    if not complete:
        return None, None, False
    problem = summary_problem(handle)
    summary = None
    if problem is None:
        try:
            handle.seek(0)
            summary = SeekingReader(handle).get_summary()
            if summary is not None:
                problem = index_problem(handle, summary)
        except Exception as err:  # a damaged summary section: scan the data instead
            problem = f"{type(err).__name__}: {err}"
    return (None if problem is not None else summary), problem, True


def walk_index(handle: BinaryIO, summary: Summary | None, problem: str | None) -> Summary | None:
    """Return the summary whose chunk index a walk may read on by (see :func:`read_summary`).

    That is the intact summary, or one that fails only the index check (:func:`index_problem`,
    say a chunk's opcode byte garbled) while its CRC holds: its offsets are still the writer's.
    """
    if summary is not None or problem is None or summary_problem(handle) is not None:
        return summary
    from mcap.reader import SeekingReader

    try:
        handle.seek(0)
        return SeekingReader(handle).get_summary()
    except Exception:  # a damaged summary section: no index to read on by
        return None


@dataclass
class _LostChunk:
    """A damaged chunk, completed by the message indexes written after it."""

    offset: int
    stop: int
    start_ns: int
    end_ns: int
    detail: str
    times: dict[int, list[int]] = field(default_factory=dict)  # channel id -> lost log times


@dataclass
class McapWalk:
    """Everything a walk of an MCAP data section found (see :func:`walk_data_section`)."""

    path: Path
    schemas: dict[int, Schema] = field(default_factory=dict)
    channels: dict[int, Channel] = field(default_factory=dict)
    counts: dict[int, int] = field(default_factory=dict)
    chunks: list[ChunkRef] = field(default_factory=list)
    loose_messages: bool = False
    """True when some messages lie outside chunks (the file must be read in file order)."""
    losses: list[Loss] = field(default_factory=list)
    data_end: int | None = None
    """Byte offset of the data end (or footer) record: where the summary section starts."""
    resume: dict[int, tuple[int, bool]] = field(default_factory=dict)
    """Where to read on after an unreadable record, and whether the record is a chunk (the
    chunk index tells both), by the record's offset."""
    _lost_chunks: list[_LostChunk] = field(default_factory=list)

    def stored_messages(
        self, channel_ids: Collection[int]
    ) -> Iterator[tuple[int, int, int, bytes]]:
        """Yield ``(channel id, log time, publish time, payload)`` of readable messages."""
        with self.path.open("rb") as handle:
            for msg in file_order_messages(handle, self.resume):
                if msg.channel_id in channel_ids:
                    yield msg.channel_id, msg.log_time, msg.publish_time, msg.data

    def scan_channel(self, cid: int) -> ScanChannel:
        """Return channel ``cid`` in the form of :mod:`~superlane_tools.recording.scan`."""
        channel = self.channels[cid]
        schema = self.schemas.get(channel.schema_id)
        stored = None if schema is None else ScanSchema(schema.name, schema.encoding, schema.data)
        return ScanChannel(
            cid,
            channel.topic,
            msgtype_name(schema, channel.message_encoding),
            channel.message_encoding,
            stored,
            dict(channel.metadata),
        )

    def _finish_chunk_losses(self) -> None:
        """Turn the damaged chunks into losses, naming channels found anywhere in the file."""
        for lost in self._lost_chunks:
            by_topic: dict[str, list[int]] = {}
            for cid, times in sorted(lost.times.items()):
                channel = self.channels.get(cid)
                by_topic.setdefault(channel.topic if channel else f"channel {cid}", []).extend(
                    times
                )
            self.losses.append(
                chunk_loss(
                    lost.detail,
                    (lost.offset, lost.stop),
                    by_topic,
                    (lost.start_ns, lost.end_ns + 1),
                )
            )
        self.losses.sort(key=lambda loss: loss.byte_start)


def _records_from(handle: BinaryIO, offset: int) -> Iterator[Any]:
    """Return the records of ``handle`` from byte ``offset`` (the file start when 0)."""
    from mcap.stream_reader import StreamReader

    handle.seek(offset)
    return StreamReader(handle, skip_magic=offset > 0, emit_chunks=True).records


def file_order_messages(
    handle: BinaryIO, resume: dict[int, tuple[int, bool]] | None = None
) -> Iterator[McapMessage]:
    """Yield the messages of every readable record in file order, chunks opened in place.

    Damaged chunks are passed over; an unreadable record ends the stream unless ``resume``
    (:attr:`McapWalk.resume`) says where the next readable record starts (the walk reports
    both).
    """
    from mcap.records import Chunk, DataEnd, Footer
    from mcap.records import Message as McapMessage
    from mcap.stream_reader import breakup_chunk

    records = _records_from(handle, 0)
    offset = len(MCAP_MAGIC)
    while True:
        try:
            record = next(records)
        except StopIteration:
            return
        except Exception:  # damage the walk reports
            if resume is None or offset not in resume:
                return
            at = offset
            offset, is_chunk = resume[at]
            record = _readable_chunk_at(handle, at) if is_chunk else None
            records = _records_from(handle, offset)
            if record is None:
                continue
        offset = handle.tell()
        if isinstance(record, DataEnd | Footer):
            return
        inner: list[Any] = [record]
        if isinstance(record, Chunk):
            try:
                inner = breakup_chunk(record, validate_crc=True)
            except Exception:  # a damaged chunk: the walk reports it
                continue
        for item in inner:
            if isinstance(item, McapMessage):
                yield item


def walk_data_section(
    handle: BinaryIO, path: Path, complete: bool, summary: Summary | None = None
) -> McapWalk:
    """Read every record of the data section once.

    An unreadable record ends the walk, unless the intact ``summary``'s chunk index says where
    the next readable record lies: a damaged chunk is then lost alone (its message indexes tell
    what it held) and the walk reads on after it.

    Args:
        handle: The open file (its position is changed).
        path: The file's path (named in the losses).
        complete: Whether the file ends with the closing magic.
        summary: The file's intact summary, if any.

    Returns:
        The schemas, channels, chunk positions and counts found, and the losses.
    """
    walker = _DataWalker(handle, McapWalk(path), summary)
    cut = walker.run()
    walk = walker.walk
    walk._finish_chunk_losses()
    if cut:
        return walk
    if summary is not None:  # records lost with a damaged region: the summary repeats them
        for sid, schema in summary.schemas.items():
            walk.schemas.setdefault(sid, schema)
        for cid, channel in summary.channels.items():
            walk.channels.setdefault(cid, channel)
    if not (complete and walk.data_end is not None):
        walk.losses.append(
            Loss(
                "truncated file",
                f"{path.name}: no footer; the file was cut short",
                walker.size,
                walker.size,
                start_ns=walker.last_time,
            )
        )
    return walk


class _Step(Enum):
    """How the walk goes on after an unreadable record."""

    NEXT = "read on at the next record"
    END = "the data section is over"
    CUT = "nothing to read on by: the walk ends here"


class _DataWalker:
    """The state of one :func:`walk_data_section`: where it reads and what it has found."""

    def __init__(self, handle: BinaryIO, walk: McapWalk, summary: Summary | None) -> None:
        self.handle = handle
        self.walk = walk
        self.summary = summary
        self.name = walk.path.name
        self.size = handle.seek(0, io.SEEK_END)
        self.records = _records_from(handle, 0)
        self.offset = len(MCAP_MAGIC)
        self.last_time: int | None = None
        self.pending: _LostChunk | None = None

    def run(self) -> bool:
        """Take records up to the data end; return True when the walk was cut short."""
        while True:
            try:
                record = next(self.records)
            except StopIteration:
                return False
            except Exception as err:  # garbled mid-record: read on at the next chunk indexed
                step = self._read_on(err)
                if step is _Step.NEXT:
                    continue
                if isinstance(step, _Step):
                    return step is _Step.CUT
                record = step
            if not self._take(record):
                return False

    def _restart(self, offset: int) -> None:
        self.offset = offset
        self.records = _records_from(self.handle, offset)

    def _read_on(self, err: Exception) -> Chunk | _Step:
        """After an unreadable record: the chunk found readable there, or how to go on."""
        why = f"{type(err).__name__}: {err}"
        offset = self.offset
        ci = _index_from(self.summary, offset)
        if ci is None:
            return self._unreadable_end(err, why)
        if ci.chunk_start_offset > offset:  # a record between chunks
            self.walk.losses.append(
                Loss(
                    "corrupt record",
                    f"{self.name}: unreadable record at byte {offset} ({why}); "
                    f"read on at the chunk at byte {ci.chunk_start_offset}",
                    offset,
                    ci.chunk_start_offset,
                )
            )
            self.walk.resume[offset] = (ci.chunk_start_offset, False)
            self._restart(ci.chunk_start_offset)
            return _Step.NEXT
        end = ci.chunk_start_offset + ci.chunk_length
        self.walk.resume[offset] = (end, True)
        chunk = _readable_chunk_at(self.handle, offset)  # its prefix may be all that is garbled
        if chunk is None:  # lose the chunk; its message indexes tell what it held
            self._lose_chunk(
                _LostChunk(
                    offset,
                    end,
                    ci.message_start_time,
                    ci.message_end_time,
                    f"{self.name}: chunk at byte {offset}: {why}",
                )
            )
            self._restart(end)
            return _Step.NEXT
        self.records = _records_from(self.handle, end)
        return chunk

    def _unreadable_end(self, err: Exception, why: str) -> _Step:
        """An unreadable record with no chunk indexed after it: the end, or a cut file."""
        offset = self.offset
        if self.summary is not None and self.summary.chunk_indexes:
            # after the last chunk (its message indexes, the data end): nothing is lost
            self.walk.losses.append(
                Loss(
                    "corrupt record",
                    f"{self.name}: unreadable record at byte {offset} ({why}), "
                    "after the last chunk the index lists",
                    offset,
                    self.size,
                )
            )
            self.walk.data_end = offset
            return _Step.END
        # cut, or garbled with no index to read on by
        self.walk.losses.append(
            Loss(
                "truncated file",
                f"{self.name}: unreadable from byte {offset} "
                f"({type(err).__name__}); later messages are lost",
                offset,
                self.size,
                start_ns=self.last_time,
            )
        )
        return _Step.CUT

    def _lose_chunk(self, lost: _LostChunk) -> None:
        self.pending = lost
        self.walk._lost_chunks.append(lost)

    def _count(self, msg: McapMessage) -> None:
        self.walk.counts[msg.channel_id] = self.walk.counts.get(msg.channel_id, 0) + 1
        self.last_time = max(msg.log_time, self.last_time or 0)

    def _take(self, record: Any) -> bool:
        """Take one record into the walk; return False at the data end."""
        from mcap.records import Channel, Chunk, DataEnd, Footer, MessageIndex, Schema
        from mcap.records import Message as McapMessage

        if isinstance(record, MessageIndex):
            if self.pending is not None:
                times = [t for t, _ in record.records]
                if times:
                    self.pending.times[record.channel_id] = times
            self.offset = self.handle.tell()
            return True
        self.pending = None
        if isinstance(record, Chunk):
            self._take_chunk(record)
        elif isinstance(record, Schema):
            self.walk.schemas[record.id] = record
        elif isinstance(record, Channel):
            self.walk.channels[record.id] = record
        elif isinstance(record, McapMessage):
            self.walk.loose_messages = True
            self._count(record)
        elif isinstance(record, Footer | DataEnd):
            # The summary after the data end repeats schemas and channels; those of the data
            # section are the ones messages were written with (and a damaged summary must not
            # override them).
            self.walk.data_end = self.offset
            return False
        self.offset = self.handle.tell()
        return True

    def _take_chunk(self, record: Chunk) -> None:
        """Take a chunk's schemas, channels and messages, or lose it (bad CRC or compression)."""
        from mcap.records import Channel, Schema
        from mcap.records import Message as McapMessage
        from mcap.stream_reader import breakup_chunk

        try:
            inner = breakup_chunk(record, validate_crc=True)
        except Exception as err:  # bad CRC or compression: skip this chunk only
            self._lose_chunk(
                _LostChunk(
                    self.offset,
                    self.handle.tell(),
                    record.message_start_time,
                    record.message_end_time,
                    f"{self.name}: chunk at byte {self.offset}: {type(err).__name__}: {err}",
                )
            )
            return
        ids: set[int] = set()
        for item in inner:
            if isinstance(item, Schema):
                self.walk.schemas[item.id] = item
            elif isinstance(item, Channel):
                self.walk.channels[item.id] = item
            elif isinstance(item, McapMessage):
                ids.add(item.channel_id)
                self._count(item)
        self.walk.chunks.append(
            ChunkRef(
                self.offset, record.message_start_time, record.message_end_time, frozenset(ids)
            )
        )


def _index_from(summary: Summary | None, offset: int) -> ChunkIndex | None:
    """Return the first chunk index of ``summary`` at or after byte ``offset``, if any."""
    if summary is None:
        return None
    after = [ci for ci in summary.chunk_indexes if ci.chunk_start_offset >= offset]
    return min(after, key=lambda ci: ci.chunk_start_offset, default=None)


def read_chunk_at(handle: BinaryIO, offset: int) -> Chunk:
    """Read the chunk record at ``offset`` without its length prefix (as the indexed reader)."""
    from mcap.data_stream import ReadDataStream
    from mcap.records import Chunk

    handle.seek(offset + RECORD_PREFIX)
    chunk: Chunk = Chunk.read(ReadDataStream(handle))
    return chunk


def _readable_chunk_at(handle: BinaryIO, offset: int) -> Chunk | None:
    """Return the chunk record at ``offset`` (see :func:`read_chunk_at`), None if unreadable."""
    try:
        return read_chunk_at(handle, offset)
    except Exception:  # the walk reports the chunk lost
        return None


def scan_mcap_file(path: Path) -> RecordingScan:
    """Scan ``path`` (see :func:`superlane_tools.recording.scan.scan_mcap`)."""
    try:
        handle = path.open("rb")
    except OSError as err:
        raise RecordingError(f"cannot open {path}: {err.strerror}") from err
    with handle:
        if handle.read(len(MCAP_MAGIC)) != MCAP_MAGIC:
            raise RecordingError(f"{path} is not a recording: no MCAP magic at the start")
        summary, problem, complete = read_summary(handle)
        walk = walk_data_section(handle, path, complete, walk_index(handle, summary, problem))
    losses = list(walk.losses)
    if problem is not None:
        size = path.stat().st_size
        start = walk.data_end if walk.data_end is not None else size
        losses.insert(0, Loss("damaged summary", f"{path.name}: {problem}", start, size, 0))
    return RecordingScan(
        path=path,
        format="mcap",
        channels={cid: walk.scan_channel(cid) for cid in sorted(walk.channels)},
        message_counts=dict(walk.counts),
        losses=tuple(losses),
        complete=complete and not losses,
        _walk=walk,
    )
