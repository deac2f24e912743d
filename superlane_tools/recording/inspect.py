"""File-level facts for ``slt info``: MCAP summary section, metadata, attachments, CAN ids.

:func:`mcap_file_info` reads only an MCAP's footer and summary section (plus the metadata
records it indexes), so it costs the same for a 1 MB and a 100 GB file; :func:`summary_from_mcap`
turns it into a :class:`~superlane_tools.recording.summary.RecordingSummary` without reading a
single message.
"""

from __future__ import annotations

from collections.abc import Collection
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from superlane_tools.recording._mcap_decode import msgtype_name
from superlane_tools.recording.base import Recording, field_value
from superlane_tools.recording.formats.mcap import MAGIC
from superlane_tools.recording.summary import RecordingSummary, TopicSummary, rate_hz

_NS = 1e9
CAN_MSGTYPES = frozenset({"can_msgs/msg/Frame"})


@dataclass(frozen=True)
class McapFileInfo:
    """What an MCAP's summary section says.

    Attributes:
        size_bytes: File size, bytes.
        profile: Header profile (``ros1``, ``ros2``, ``""``).
        library: Header library string.
        compression: Chunk compressions used (``zstd``, ``lz4``, ``""`` for none).
        chunk_count: Number of chunks.
        has_statistics: True when the summary holds a Statistics record (message counts).
        metadata: Metadata records: name and their key/value pairs.
        attachments: Attachments: name, media type, size in bytes, log time (ns).
        channel_counts: Messages per topic (from the Statistics record).
        channel_spans: ``(first, last)`` log time per topic, ns, from the chunk index (the span of
            the chunks that hold the topic: exact at chunk granularity).
        channel_types: ``(message type, encoding)`` per topic.
    """

    size_bytes: int
    profile: str
    library: str
    compression: tuple[str, ...]
    chunk_count: int
    has_statistics: bool
    metadata: tuple[dict[str, Any], ...] = ()
    attachments: tuple[dict[str, Any], ...] = ()
    channel_counts: dict[str, int] = field(default_factory=dict)
    channel_spans: dict[str, tuple[int, int]] = field(default_factory=dict)
    channel_types: dict[str, tuple[str, str]] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """Return JSON-ready data (without the per-channel tables, which the topics show)."""
        out = asdict(self)
        for key in ("channel_counts", "channel_spans", "channel_types"):
            out.pop(key)
        out["compression"] = list(self.compression)
        return out


def mcap_file_info(path: Path) -> McapFileInfo | None:
    """Read an MCAP's summary section; None when the file is not an MCAP or has no summary."""
    from mcap.reader import make_reader

    if not path.is_file():
        return None
    try:
        with path.open("rb") as handle:
            if handle.read(len(MAGIC)) != MAGIC:
                return None
            handle.seek(0)
            reader = make_reader(handle)
            header = reader.get_header()
            summary = reader.get_summary()
            if summary is None:
                return None
            metadata = tuple(
                {"name": m.name, "data": dict(m.metadata)} for m in reader.iter_metadata()
            )
    except Exception:  # a damaged footer or summary: the caller scans the messages instead
        return None
    stats = summary.statistics
    topic_of = {cid: ch.topic for cid, ch in summary.channels.items()}
    counts: dict[str, int] = {}
    if stats is not None:
        for cid, count in stats.channel_message_counts.items():
            if cid in topic_of:
                counts[topic_of[cid]] = counts.get(topic_of[cid], 0) + int(count)
    spans: dict[str, tuple[int, int]] = {}
    for chunk in summary.chunk_indexes:
        for cid in chunk.message_index_offsets:
            topic = topic_of.get(cid)
            if topic is None:
                continue
            lo, hi = spans.get(topic, (chunk.message_start_time, chunk.message_end_time))
            spans[topic] = (min(lo, chunk.message_start_time), max(hi, chunk.message_end_time))
    types = {
        ch.topic: (msgtype_name(summary.schemas.get(ch.schema_id), ch.message_encoding),
                   ch.message_encoding)
        for ch in summary.channels.values()
    }  # fmt: skip
    attachments = tuple(
        {"name": a.name, "media_type": a.media_type, "size_bytes": a.data_size,
         "log_time_ns": a.log_time}
        for a in summary.attachment_indexes
    )  # fmt: skip
    return McapFileInfo(
        size_bytes=path.stat().st_size,
        profile=header.profile,
        library=header.library,
        compression=tuple(sorted({c.compression for c in summary.chunk_indexes})),
        chunk_count=len(summary.chunk_indexes),
        has_statistics=stats is not None,
        metadata=metadata,
        attachments=attachments,
        channel_counts=counts,
        channel_spans=spans,
        channel_types=types,
    )


def summary_from_mcap(path: Path, info: McapFileInfo) -> RecordingSummary:
    """Build a recording summary from the summary section alone (no message is read).

    Rates are mean rates ``(count - 1) / span`` over the chunk-index span; largest gaps and
    header-stamp offsets need every message and are left unknown (``slt info --scan``).
    """
    topics = []
    for topic in sorted(info.channel_types):
        msgtype, encoding = info.channel_types[topic]
        count = info.channel_counts.get(topic, 0)
        first, last = info.channel_spans.get(topic, (None, None))
        span = (last - first) if first is not None and last is not None else 0
        rate, why = rate_hz(count, span)
        topics.append(
            TopicSummary(
                topic, msgtype, encoding, count, rate, None, first, last, span / _NS, None, why
            )
        )
    firsts = [t.first_ns for t in topics if t.first_ns is not None]
    lasts = [t.last_ns for t in topics if t.last_ns is not None]
    start = min(firsts) if firsts else None
    end = max(lasts) if lasts else None
    return RecordingSummary(
        path=str(path),
        container="mcap",
        topics=tuple(topics),
        message_count=sum(t.count for t in topics),
        start_ns=start,
        end_ns=end,
        duration_s=(end - start) / _NS if start is not None and end is not None else 0.0,
    )


@dataclass(frozen=True)
class CanIdStats:
    """Frames of one CAN id on one topic.

    Attributes:
        topic: CAN topic or log channel.
        can_id: Arbitration id.
        count: Frames.
        rate_hz: Mean rate over the id's own span, Hz (None for one frame or a span under
            :data:`~superlane_tools.recording.summary.MIN_RATE_SPAN_NS`).
        dlcs: Data lengths seen, sorted.
    """

    topic: str
    can_id: int
    count: int
    rate_hz: float | None
    dlcs: tuple[int, ...]


def can_id_stats(rec: Recording, topics: Collection[str]) -> list[CanIdStats]:
    """Return per-id counts, mean rates and DLCs of the CAN topics (one pass over them)."""
    acc: dict[tuple[str, int], list[Any]] = {}
    for msg in rec.messages(topics=list(topics)):
        can_id = field_value(msg.data, "id", "arbitration_id")
        if can_id is None:
            continue
        dlc = field_value(msg.data, "dlc")
        key = (msg.topic, int(can_id))
        entry = acc.get(key)
        if entry is None:
            acc[key] = [1, msg.log_time_ns, msg.log_time_ns, {int(dlc or 0)}]
        else:
            entry[0] += 1
            entry[1] = min(entry[1], msg.log_time_ns)
            entry[2] = max(entry[2], msg.log_time_ns)
            entry[3].add(int(dlc or 0))
    out = []
    for (topic, can_id), (count, first, last, dlcs) in sorted(acc.items()):
        rate, _ = rate_hz(count, last - first)
        out.append(CanIdStats(topic, can_id, count, rate, tuple(sorted(dlcs))))
    return out
