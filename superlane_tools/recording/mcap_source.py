"""MCAP recordings: indexed reading in log-time order, a scanning fallback for damaged files."""

from __future__ import annotations

import heapq
import queue
from collections import deque
from collections.abc import Collection, Hashable, Iterator, Sequence
from concurrent.futures import Future, ThreadPoolExecutor
from itertools import pairwise
from pathlib import Path
from typing import TYPE_CHECKING, Any, BinaryIO, cast

from superlane_tools.recording._mcap_decode import McapDecoders, header_first, msgtype_name
from superlane_tools.recording._mcap_scan import (
    RECORD_PREFIX,
    ChunkRef,
    file_order_messages,
    read_summary,
    walk_data_section,
    walk_index,
)
from superlane_tools.recording.base import (
    SkipLog,
    in_range,
    raw_header_stamp_ns,
    stamp_ns_of,
    storable_time,
)
from superlane_tools.recording.decoding import Decode, RawSource
from superlane_tools.recording.errors import RecordingError
from superlane_tools.recording.formats.mcap import MAGIC as MCAP_MAGIC
from superlane_tools.records import RawMessage, Skipped, TopicInfo

if TYPE_CHECKING:
    from mcap.decoder import DecoderFactory
    from mcap.records import Channel, Schema
    from mcap.records import Message as McapMessage
    from mcap.summary import Summary

PREFETCH_CHUNKS = 3
"""Chunks loaded ahead of the consumer by the background loader threads."""
LOADER_THREADS = 2
"""Threads loading chunks: each one's read, decompression and CRC check release the GIL."""


class McapRecording(RawSource):
    """An MCAP file opened for streaming (see :class:`~superlane_tools.recording.base.Recording`).

    Complete files are read through their chunk index. Files without a usable summary (cut
    short, never finished, or damaged at the end) are scanned once at open time: every complete
    chunk before the damage is kept and the loss is reported in :attr:`skipped`. Chunks whose CRC
    or compression is broken are skipped and reported; reading continues after them.
    """

    def __init__(self, path: str | Path, decoder_factories: Sequence[DecoderFactory] = ()) -> None:
        """Open the file and read its index (or scan it when the index is unusable).

        Args:
            path: The MCAP file.
            decoder_factories: mcap decoder factories tried before the built-in ones
                (``mcap_ros2``, ``mcap_ros1``, ``mcap_protobuf``, JSON) when messages are decoded.

        Raises:
            RecordingError: If the file cannot be opened or is not MCAP.
        """
        self.path = Path(path)
        try:
            self._file = self.path.open("rb")
        except OSError as err:
            raise RecordingError(f"cannot open {self.path}: {err.strerror}") from err
        self._open_skips = SkipLog()
        self._iter_skips = SkipLog()
        self._schemas: dict[int, Schema] = {}
        self._channels: dict[int, Channel] = {}
        self._counts: dict[int, int] | None = None
        self._chunks: list[ChunkRef] = []
        self._loose_messages = False
        self._resume: dict[int, tuple[int, bool]] = {}  # the walk's read-on points
        self._decoders = McapDecoders(decoder_factories)
        self._header_first: dict[int, bool] = {}
        self._summary: Summary | None = None
        self.indexed = False
        try:
            self._load_index()
        except BaseException:
            self._file.close()
            raise

    def close(self) -> None:
        """Close the file."""
        self._file.close()

    def metadata(self) -> dict[str, dict[str, str]]:
        """Return the file's metadata records by name (empty when the summary is unreadable).

        Read through a second handle, so that a message iteration in progress keeps its place.
        """
        from mcap.reader import make_reader

        try:
            with self.path.open("rb") as handle:
                return {r.name: dict(r.metadata) for r in make_reader(handle).iter_metadata()}
        except Exception:  # a damaged summary or odd metadata: no records
            return {}

    # -- index -----------------------------------------------------------------------------

    def _load_index(self) -> None:
        head = self._file.read(len(MCAP_MAGIC))
        if head != MCAP_MAGIC:
            raise RecordingError(f"{self.path} is not a recording: no MCAP magic at the start")
        summary, problem, complete = read_summary(self._file)
        if problem is not None:
            self._open_skips.add(
                "damaged summary",
                f"{self.path.name}: {problem}; the data section was scanned instead",
                0,
            )
        self._summary = summary
        self.indexed = summary is not None and bool(summary.chunk_indexes)
        """True when messages are read through the file's chunk index (a complete file)."""
        if summary is not None and summary.chunk_indexes:
            self._schemas = dict(summary.schemas)
            self._channels = dict(summary.channels)
            if summary.statistics is not None:
                self._counts = dict(summary.statistics.channel_message_counts)
            self._chunks = [
                ChunkRef(
                    ci.chunk_start_offset,
                    ci.message_start_time,
                    ci.message_end_time,
                    frozenset(ci.message_index_offsets) or None,
                )
                for ci in summary.chunk_indexes
            ]
            return
        index = walk_index(self._file, summary, problem)
        walk = walk_data_section(self._file, self.path, complete, index)
        self._schemas, self._channels = walk.schemas, walk.channels
        self._counts, self._chunks = walk.counts, walk.chunks
        self._loose_messages, self._resume = walk.loose_messages, walk.resume
        for loss in walk.losses:
            self._open_skips.add(loss.what, loss.detail, 0)

    # -- public API ------------------------------------------------------------------------

    @property
    def skipped(self) -> list[Skipped]:
        """Problems found at open time plus those of the latest message pass."""
        return self._open_skips.items() + self._iter_skips.items()

    def topics(self) -> list[TopicInfo]:
        """Return one entry per topic, sorted by name (counts from the statistics or scan)."""
        by_topic: dict[str, TopicInfo] = {}
        for cid, channel in self._channels.items():
            count = None if self._counts is None else self._counts.get(cid, 0)
            schema = self._schemas.get(channel.schema_id)
            known = by_topic.get(channel.topic)
            if known is None:
                by_topic[channel.topic] = TopicInfo(
                    channel.topic,
                    msgtype_name(schema, channel.message_encoding),
                    channel.message_encoding,
                    count,
                )
            elif count is not None and known.message_count is not None:
                by_topic[channel.topic] = known._replace(message_count=known.message_count + count)
        return [by_topic[name] for name in sorted(by_topic)]

    def _pass_skips(self) -> SkipLog:
        return self._iter_skips

    def _keyed_raw(
        self, topics: Collection[str] | None, start_ns: int | None, stop_ns: int | None
    ) -> Iterator[tuple[Hashable, RawMessage]]:
        """Yield ``(channel id, raw message)`` in log-time order, ``[start_ns, stop_ns)``."""
        msgtypes: dict[int, str] = {}
        for channel, msg in self._records(topics, start_ns, stop_ns):
            msgtype = msgtypes.get(channel.id)
            if msgtype is None:
                schema = self._schemas.get(channel.schema_id)
                msgtype = msgtypes[channel.id] = msgtype_name(schema, channel.message_encoding)
            raw = RawMessage(
                channel.topic, msg.log_time, msgtype, channel.message_encoding, msg.data
            )
            yield channel.id, raw

    def _decoder_for(self, key: Hashable, raw: RawMessage) -> Decode:
        """Return the decoder of channel ``key`` (mcap decoder factories, then the fallbacks)."""
        del raw
        channel = self._channels[cast("int", key)]
        decode = self._decoders.decoder_for(
            channel.message_encoding, self._schemas.get(channel.schema_id)
        )
        return lambda raw: decode(raw.payload)

    def peek_stamp_ns(self, raw: RawMessage) -> int | None:
        """Return the header stamp of ``raw`` (ns) reading as little of it as possible."""
        channel = next((c for c in self._channels.values() if c.topic == raw.topic), None)
        if channel is None:
            return None
        if raw.encoding in {"cdr", "ros1"}:
            first = self._header_first.get(channel.id)
            if first is None:
                first = header_first(self._schemas.get(channel.schema_id), raw.encoding)
                self._header_first[channel.id] = first
            return raw_header_stamp_ns(raw.encoding, raw.payload) if first else None
        try:
            decoder = self._decoders.decoder_for(raw.encoding, self._schemas.get(channel.schema_id))
            return stamp_ns_of(decoder(raw.payload))
        except Exception:  # unknown or undecodable: no stamp
            return None

    # -- record iteration ------------------------------------------------------------------

    def _wanted(self, topics: Collection[str] | None) -> set[int]:
        if topics is None:
            return set(self._channels)
        names = set(topics)
        return {cid for cid, ch in self._channels.items() if ch.topic in names}

    def _records(
        self, topics: Collection[str] | None, start_ns: int | None, stop_ns: int | None
    ) -> Iterator[tuple[Channel, McapMessage]]:
        self._iter_skips.clear()
        wanted = self._wanted(topics)
        if self._loose_messages:
            yield from self._records_in_file_order(wanted, start_ns, stop_ns)
            return
        candidates = sorted(
            (
                c
                for c in self._chunks
                if (c.channel_ids is None or c.channel_ids & wanted)
                and (start_ns is None or c.end_ns >= start_ns)
                and (stop_ns is None or c.start_ns < stop_ns)
            ),
            key=lambda c: (c.start_ns, c.offset),
        )
        if not candidates:
            return
        heap: list[tuple[int, int, int, McapMessage]] = []
        next_chunk = 0
        loader = _ChunkPrefetcher(self.path, candidates)

        def load(ref: ChunkRef) -> list[McapMessage]:
            return [
                msg
                for msg in self._chunk_result(ref, loader.next())
                if msg.channel_id in wanted
                and in_range(msg.log_time, start_ns, stop_ns)
                and self._storable(msg)
            ]

        try:
            while next_chunk < len(candidates) or heap:
                if not heap:  # the usual case: chunks one after the other, each in time order
                    ref = candidates[next_chunk]
                    next_chunk += 1
                    msgs = load(ref)
                    alone = next_chunk == len(candidates) or (
                        candidates[next_chunk].start_ns > ref.end_ns
                    )
                    if alone and all(a.log_time <= b.log_time for a, b in pairwise(msgs)):
                        for msg in msgs:
                            yield self._channels[msg.channel_id], msg
                        continue
                    for index, msg in enumerate(msgs):
                        heapq.heappush(heap, (msg.log_time, ref.offset, index, msg))
                # Load every chunk that may hold a message earlier than the earliest one queued.
                while next_chunk < len(candidates) and (
                    not heap or candidates[next_chunk].start_ns <= heap[0][0]
                ):
                    ref = candidates[next_chunk]
                    next_chunk += 1
                    for index, msg in enumerate(load(ref)):
                        heapq.heappush(heap, (msg.log_time, ref.offset, index, msg))
                if heap:
                    msg = heapq.heappop(heap)[3]
                    yield self._channels[msg.channel_id], msg
        finally:
            loader.close()

    def _storable(self, msg: McapMessage) -> bool:
        """Return True for a log time that fits int64 ns; count the others as skipped."""
        if storable_time(msg.log_time):
            return True
        channel = self._channels.get(msg.channel_id)
        self._iter_skips.add(
            "log time beyond int64 ns (after year 2262)",
            channel.topic if channel else f"channel {msg.channel_id}",
        )
        return False

    def _chunk_result(
        self, ref: ChunkRef, loaded: list[McapMessage] | Exception
    ) -> list[McapMessage]:
        """Return a loaded chunk's messages; report a damaged chunk and return none."""
        if not isinstance(loaded, Exception):
            return loaded
        lost = self._indexed_count(ref)
        self._iter_skips.add(
            "corrupt chunk",
            f"{self.path.name}: chunk at byte {ref.offset}: {type(loaded).__name__}: {loaded}",
            lost,
        )
        return []

    def _indexed_count(self, ref: ChunkRef) -> int:
        """Count a chunk's messages from its message indexes (0 when they cannot be read)."""
        from mcap.records import MessageIndex
        from mcap.stream_reader import StreamReader

        try:
            summary = self._summary
            if summary is None:
                return 0
            index = next(ci for ci in summary.chunk_indexes if ci.chunk_start_offset == ref.offset)
            total = 0
            for offset in index.message_index_offsets.values():
                self._file.seek(offset)
                record: Any = next(StreamReader(self._file, skip_magic=True).records)
                if isinstance(record, MessageIndex):
                    total += len(record.records)
            return total
        except Exception:  # the count is a courtesy; never fail on it
            return 0

    def _records_in_file_order(
        self, wanted: set[int], start_ns: int | None, stop_ns: int | None
    ) -> Iterator[tuple[Channel, McapMessage]]:
        """Stream an unchunked (or partly unchunked) file in the order its records lie."""
        for item in file_order_messages(self._file, self._resume):
            if (
                item.channel_id in wanted
                and in_range(item.log_time, start_ns, stop_ns)
                and self._storable(item)
            ):
                yield self._channels[item.channel_id], item


def _load_chunk(handle: BinaryIO, ref: ChunkRef) -> list[McapMessage] | Exception:
    """Read, decompress and CRC-check one chunk; return its messages or the error."""
    from mcap.data_stream import ReadDataStream
    from mcap.records import Chunk
    from mcap.records import Message as McapMessage
    from mcap.stream_reader import breakup_chunk

    try:
        handle.seek(ref.offset + RECORD_PREFIX)
        chunk = Chunk.read(ReadDataStream(handle))
        records = breakup_chunk(chunk, validate_crc=True)
    except Exception as err:  # bad CRC, bad compression, cut record
        return err
    return [r for r in records if isinstance(r, McapMessage)]


class _ChunkPrefetcher:
    """Loads chunks in background threads, a few ahead of the consumer, in a given order.

    Reading, zstd/lz4 decompression and the CRC check release the GIL, so they overlap with
    each other and with decoding and writing in the consuming thread (two loaders: the reader
    was the bottleneck of ``slt extract --frames none`` with one). Each thread reads through a
    file handle of its own; at most :data:`PREFETCH_CHUNKS` loaded chunks wait in memory.
    """

    def __init__(self, path: Path, order: list[ChunkRef]) -> None:
        self._handles: queue.SimpleQueue[BinaryIO] = queue.SimpleQueue()
        self._opened: list[BinaryIO] = []
        try:
            for _ in range(LOADER_THREADS):  # a handle per loader: seek + read are not shared
                self._opened.append(path.open("rb"))
                self._handles.put(self._opened[-1])
        except OSError as err:
            for handle in self._opened:
                handle.close()
            raise RecordingError(f"cannot open {path}: {err.strerror}") from err
        self._pool = ThreadPoolExecutor(LOADER_THREADS, thread_name_prefix="slt-mcap-chunks")
        self._order = iter(order)
        self._queue: deque[Future[list[McapMessage] | Exception]] = deque()
        for _ in range(PREFETCH_CHUNKS):
            self._submit()

    def _load(self, ref: ChunkRef) -> list[McapMessage] | Exception:
        handle = self._handles.get()
        try:
            return _load_chunk(handle, ref)
        finally:
            self._handles.put(handle)

    def _submit(self) -> None:
        ref = next(self._order, None)
        if ref is not None:
            self._queue.append(self._pool.submit(self._load, ref))

    def next(self) -> list[McapMessage] | Exception:
        """Return the next chunk of the order (its messages or its loading error)."""
        loaded = self._queue.popleft().result()
        self._submit()
        return loaded

    def close(self) -> None:
        """Stop the threads (finishing the chunks in progress) and close the handles."""
        self._pool.shutdown(wait=True, cancel_futures=True)
        for handle in self._opened:
            handle.close()
