"""Records of a damaged-file scan: channels, messages, losses (the API: ``recording.scan``)."""

from __future__ import annotations

from collections.abc import Collection, Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal, NamedTuple, Protocol

from superlane_tools.records import Skipped

ScanFormat = Literal["mcap", "ros1"]


class ScanSchema(NamedTuple):
    """A message definition as the file stores it (enough to write the messages again).

    Attributes:
        name: Type name as stored: ``sensor_msgs/msg/Image`` (ROS 2), ``sensor_msgs/Image``
            (ROS 1), ``foxglove.CompressedImage`` (protobuf).
        encoding: Schema encoding in MCAP terms: ``ros2msg``, ``ros2idl``, ``ros1msg``,
            ``protobuf``, ``jsonschema`` (empty when unknown).
        data: The definition bytes (``.msg`` text, IDL, a protobuf ``FileDescriptorSet``).
    """

    name: str
    encoding: str
    data: bytes


class ScanChannel(NamedTuple):
    """One channel (MCAP) or connection (ROS 1) found by the scan.

    Attributes:
        id: Channel or connection id in the file.
        topic: Topic name.
        msgtype: Message type name in ROS 2 form (``pkg/msg/Name``; protobuf names unchanged).
        message_encoding: ``cdr``, ``ros1``, ``protobuf``, ``json``, ...
        schema: The stored definition, None for a schemaless channel.
        metadata: Channel metadata (MCAP), or a ROS 1 connection's ``md5sum``, ``callerid``
            and ``latching`` when present.
    """

    id: int
    topic: str
    msgtype: str
    message_encoding: str
    schema: ScanSchema | None
    metadata: Mapping[str, str]


class ScannedMessage(NamedTuple):
    """One readable message: its channel, times (ns) and the payload bytes as stored."""

    channel: ScanChannel
    log_time_ns: int
    publish_time_ns: int
    payload: bytes


class TopicLoss(NamedTuple):
    """What one topic lost.

    Attributes:
        topic: Topic name (``channel <id>`` when the channel record itself was lost).
        n_messages: Messages lost, None when unknown (a file cut short has no index to tell).
        start_ns: Log time of the first lost message, None when unknown.
        stop_ns: Just after the last lost message (exclusive), None when unknown.
    """

    topic: str
    n_messages: int | None
    start_ns: int | None
    stop_ns: int | None


class Loss(NamedTuple):
    """One damaged region of the file and what it cost.

    Attributes:
        what: Kind: ``corrupt chunk``, ``truncated file``, ``damaged summary`` or ``corrupt
            record`` (an unreadable MCAP record outside the chunks the intact chunk index
            lists, such as a message index: no message lost, the scan read on at the next
            chunk).
        detail: One line for people (the same text the sources report in ``skipped``).
        byte_start: First unreadable byte.
        byte_stop: End of the unreadable bytes (exclusive; the file size for a cut file).
        n_messages: Messages lost, None when unknown.
        start_ns: First lost log time when known. For a file cut short it is the latest log
            time read before the cut (a recorder writes in time order, so the loss came after).
        stop_ns: End of the lost log times (exclusive), None when unknown.
        topics: Per-topic losses, when the indexes written after a damaged chunk tell them
            (MCAP message indexes, ROS 1 index data records); empty when unknown.
    """

    what: str
    detail: str
    byte_start: int
    byte_stop: int
    n_messages: int | None = None
    start_ns: int | None = None
    stop_ns: int | None = None
    topics: tuple[TopicLoss, ...] = ()


class StoredMessages(Protocol):
    """A format's walk: re-reads the messages it found."""

    def stored_messages(
        self, channel_ids: Collection[int]
    ) -> Iterator[tuple[int, int, int, bytes]]:
        """Yield ``(channel id, log time, publish time, payload)`` in file order."""
        ...


@dataclass(frozen=True)
class RecordingScan:
    """The result of scanning one file: channels, readable counts, losses, and the messages.

    Attributes:
        path: The scanned file.
        format: ``mcap`` or ``ros1``.
        channels: Every channel (MCAP) or connection (ROS 1) found, by id.
        message_counts: Readable messages per channel id.
        losses: The damaged regions, in file order (empty for an intact file).
        complete: True when the file ends properly (MCAP footer and closing magic, ROS 1 index
            section) and nothing was lost.
    """

    path: Path
    format: ScanFormat
    channels: Mapping[int, ScanChannel]
    message_counts: Mapping[int, int]
    losses: tuple[Loss, ...]
    complete: bool
    _walk: StoredMessages = field(repr=False, compare=False)

    def messages(self, topics: Collection[str] | None = None) -> Iterator[ScannedMessage]:
        """Yield every readable message of ``topics`` (all if None) in the order of the file.

        MCAP files are read again chunk by chunk (memory stays flat); a ROS 1 scan holds the
        messages it found. Within a chunk, messages come as the recorder wrote them (usually in
        log-time order); :attr:`ScannedMessage.payload` is the stored bytes.
        """
        wanted = None if topics is None else set(topics)
        ids = {cid for cid, ch in self.channels.items() if wanted is None or ch.topic in wanted}
        for cid, log_time, publish_time, payload in self._walk.stored_messages(ids):
            yield ScannedMessage(self.channels[cid], log_time, publish_time, payload)

    def topic_counts(self) -> dict[str, int]:
        """Return the readable messages per topic, sorted by topic name."""
        counts: dict[str, int] = {}
        for cid, channel in self.channels.items():
            counts[channel.topic] = counts.get(channel.topic, 0) + self.message_counts.get(cid, 0)
        return dict(sorted(counts.items()))

    def lost_by_topic(self) -> dict[str, TopicLoss]:
        """Return the per-topic losses summed over every damaged region, sorted by topic.

        A topic's count is None when some region lost an unknown number of its messages; a
        region whose topics are unknown (a file cut short) is not attributed to any topic: see
        :attr:`losses` for it.
        """
        merged: dict[str, TopicLoss] = {}
        for loss in self.losses:
            for part in loss.topics:
                known = merged.get(part.topic)
                merged[part.topic] = part if known is None else _merge(known, part)
        return dict(sorted(merged.items()))

    def skipped(self) -> list[Skipped]:
        """Return the losses as the sources report them (one entry per damaged region)."""
        return [Skipped(loss.what, loss.detail, loss.n_messages or 0) for loss in self.losses]


def chunk_loss(
    detail: str,
    byte_range: tuple[int, int],
    lost_times: Mapping[str, list[int]],
    time_range: tuple[int | None, int | None] = (None, None),
) -> Loss:
    """Return the ``corrupt chunk`` loss of a damaged chunk.

    Args:
        detail: One line for people.
        byte_range: The chunk's bytes, ``[start, stop)``.
        lost_times: Log times of the lost messages by topic, as the indexes written after the
            chunk list them (empty when unknown).
        time_range: The chunk's log-time range when its header has one (``[start, stop)``),
            else the range of ``lost_times``.
    """
    parts = tuple(
        TopicLoss(topic, len(times), min(times), max(times) + 1)
        for topic, times in lost_times.items()
        if times
    )
    start_ns, stop_ns = time_range
    if start_ns is None:
        start_ns = min((p.start_ns for p in parts if p.start_ns is not None), default=None)
    if stop_ns is None:
        stop_ns = max((p.stop_ns for p in parts if p.stop_ns is not None), default=None)
    count = sum(p.n_messages or 0 for p in parts) if parts else None
    return Loss("corrupt chunk", detail, *byte_range, count, start_ns, stop_ns, parts)


def _merge(a: TopicLoss, b: TopicLoss) -> TopicLoss:
    count = None if a.n_messages is None or b.n_messages is None else a.n_messages + b.n_messages
    starts = [t for t in (a.start_ns, b.start_ns) if t is not None]
    stops = [t for t in (a.stop_ns, b.stop_ns) if t is not None]
    return TopicLoss(a.topic, count, min(starts, default=None), max(stops, default=None))
