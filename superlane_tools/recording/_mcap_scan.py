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
    from mcap.records import Channel, Chunk, DataEnd, Footer, MessageIndex, Schema
    from mcap.records import Message as McapMessage
    from mcap.stream_reader import breakup_chunk

    walk = McapWalk(path)
    name = path.name
    size = handle.seek(0, io.SEEK_END)
    records = _records_from(handle, 0)
    offset = len(MCAP_MAGIC)
    last_time: int | None = None
    pending: _LostChunk | None = None
    while True:
        try:
            record = next(records)
        except StopIteration:
            break
        except Exception as err:  # garbled mid-record: read on at the next chunk indexed
            why = f"{type(err).__name__}: {err}"
            ci = _index_from(summary, offset)
            if ci is None and summary is not None and summary.chunk_indexes:
                # after the last chunk (its message indexes, the data end): nothing is lost
                walk.losses.append(
                    Loss(
                        "corrupt record",
                        f"{name}: unreadable record at byte {offset} ({why}), "
                        "after the last chunk the index lists",
                        offset,
                        size,
                    )
                )
                walk.data_end = offset
                break
            if ci is None:  # cut, or garbled with no index to read on by
                walk.losses.append(
                    Loss(
                        "truncated file",
                        f"{name}: unreadable from byte {offset} "
                        f"({type(err).__name__}); later messages are lost",
                        offset,
                        size,
                        start_ns=last_time,
                    )
                )
                walk._finish_chunk_losses()
                return walk
            if ci.chunk_start_offset > offset:  # a record between chunks
                walk.losses.append(
                    Loss(
                        "corrupt record",
                        f"{name}: unreadable record at byte {offset} ({why}); "
                        f"read on at the chunk at byte {ci.chunk_start_offset}",
                        offset,
                        ci.chunk_start_offset,
                    )
                )
                walk.resume[offset] = (ci.chunk_start_offset, False)
                offset = ci.chunk_start_offset
                records = _records_from(handle, offset)
                continue
            end = ci.chunk_start_offset + ci.chunk_length
            walk.resume[offset] = (end, True)
            chunk = _readable_chunk_at(handle, offset)  # its prefix may be all that is garbled
            if chunk is None:  # lose the chunk; its message indexes tell what it held
                pending = _LostChunk(
                    offset,
                    end,
                    ci.message_start_time,
                    ci.message_end_time,
                    f"{name}: chunk at byte {offset}: {why}",
                )
                walk._lost_chunks.append(pending)
                offset = end
                records = _records_from(handle, offset)
                continue
            record = chunk
            records = _records_from(handle, end)
        if isinstance(record, MessageIndex):
            if pending is not None:
                times = [t for t, _ in record.records]
                if times:
                    pending.times[record.channel_id] = times
            offset = handle.tell()
            continue
        pending = None
        if isinstance(record, Chunk):
            try:
                inner = breakup_chunk(record, validate_crc=True)
            except Exception as err:  # bad CRC or compression: skip this chunk only
                pending = _LostChunk(
                    offset,
                    handle.tell(),
                    record.message_start_time,
                    record.message_end_time,
                    f"{name}: chunk at byte {offset}: {type(err).__name__}: {err}",
                )
                walk._lost_chunks.append(pending)
            else:
                ids: set[int] = set()
                for item in inner:
                    if isinstance(item, Schema):
                        walk.schemas[item.id] = item
                    elif isinstance(item, Channel):
                        walk.channels[item.id] = item
                    elif isinstance(item, McapMessage):
                        ids.add(item.channel_id)
                        walk.counts[item.channel_id] = walk.counts.get(item.channel_id, 0) + 1
                        last_time = max(item.log_time, last_time or 0)
                walk.chunks.append(
                    ChunkRef(
                        offset, record.message_start_time, record.message_end_time, frozenset(ids)
                    )
                )
        elif isinstance(record, Schema):
            walk.schemas[record.id] = record
        elif isinstance(record, Channel):
            walk.channels[record.id] = record
        elif isinstance(record, McapMessage):
            walk.loose_messages = True
            walk.counts[record.channel_id] = walk.counts.get(record.channel_id, 0) + 1
            last_time = max(record.log_time, last_time or 0)
        elif isinstance(record, Footer | DataEnd):
            # The summary after the data end repeats schemas and channels; those of the data
            # section are the ones messages were written with (and a damaged summary must not
            # override them).
            walk.data_end = offset
            break
        offset = handle.tell()
    walk._finish_chunk_losses()
    if summary is not None:  # records lost with a damaged region: the summary repeats them
        for sid, schema in summary.schemas.items():
            walk.schemas.setdefault(sid, schema)
        for cid, channel in summary.channels.items():
            walk.channels.setdefault(cid, channel)
    if not (complete and walk.data_end is not None):
        walk.losses.append(
            Loss(
                "truncated file",
                f"{name}: no footer; the file was cut short",
                size,
                size,
                start_ns=last_time,
            )
        )
    return walk


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
