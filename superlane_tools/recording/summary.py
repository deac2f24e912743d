"""Per-topic statistics of a recording from one streaming pass (``slt info``)."""

from __future__ import annotations

import statistics
from array import array
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from superlane_tools.recording.base import Recording, SupportsStampPeek
from superlane_tools.records import Skipped

_NS = 1e9
_RATE_WINDOW_NS = 10_000_000_000
PROGRESS_EVERY = 2000
"""Messages between two progress callbacks."""
MIN_RATE_SPAN_NS = 1_000_000
"""Shortest time span a rate is computed over (1 ms; ``slt info`` shows spans to the ms).

Messages closer together than that were logged as one burst (or share one log time): dividing
their count by a span of a few nanoseconds gives hundreds of MHz, not a rate."""


def rate_hz(count: int, span_ns: int) -> tuple[float | None, str | None]:
    """Return the mean rate ``(count - 1) / span`` in Hz, or None and why there is none.

    Args:
        count: Messages.
        span_ns: Last minus first log time, ns.
    """
    if count == 0:
        return None, "no messages"
    if count == 1:
        return None, "one message"
    if span_ns == 0:
        return None, f"all {count} messages share one log time (span 0 s)"
    if span_ns < MIN_RATE_SPAN_NS:
        return None, (
            f"all {count} messages within {span_ns} ns (span < 1 ms): logged as one burst"
        )
    return (count - 1) * _NS / span_ns, None


@dataclass(frozen=True)
class TopicSummary:
    """Statistics of one topic.

    Attributes:
        topic: Topic name.
        msgtype: Message type, ROS 2 form for ROS types.
        encoding: Message encoding (``cdr``, ``ros1``, ``protobuf``, ``json``, ...).
        count: Messages read.
        median_rate_hz: Median message rate over the topic's whole 10 s windows, Hz (robust to
            bursts such as CAN frames logged together, and to dropouts); ``(count - 1) /
            duration`` for topics shorter than 20 s; None with fewer than 2 messages or all at
            one time.
        largest_gap_s: Largest interval between consecutive log times, seconds.
        first_ns: First log time, ns since the epoch (None without messages).
        last_ns: Last log time, ns since the epoch.
        duration_s: ``last - first``, seconds.
        median_stamp_offset_ms: Median of header stamp minus log time, ms, over the messages
            that have a stamp (None when none has).
        rate_note: Why ``median_rate_hz`` is None (None when there is a rate).
    """

    topic: str
    msgtype: str
    encoding: str
    count: int
    median_rate_hz: float | None
    largest_gap_s: float | None
    first_ns: int | None
    last_ns: int | None
    duration_s: float
    median_stamp_offset_ms: float | None
    rate_note: str | None = None


@dataclass(frozen=True)
class RecordingSummary:
    """What ``slt info`` reports about a recording.

    Attributes:
        path: The recording's path.
        container: Container kind (``mcap``, ``ros1``, ``ros2``, or the source's class name).
        topics: One entry per topic, sorted by name.
        skipped: What was skipped or lost while reading.
        message_count: Messages read over all topics.
        start_ns: Earliest log time, ns (None for an empty recording).
        end_ns: Latest log time, ns.
        duration_s: ``end - start``, seconds.
    """

    path: str
    container: str
    topics: tuple[TopicSummary, ...]
    skipped: tuple[Skipped, ...] = field(default_factory=tuple)
    message_count: int = 0
    start_ns: int | None = None
    end_ns: int | None = None
    duration_s: float = 0.0

    def to_dict(self) -> dict[str, Any]:
        """Return plain JSON-ready data."""
        out = asdict(self)
        out["skipped"] = [item._asdict() for item in self.skipped]
        return out


class _TopicStats:
    """Accumulates one topic's log-time intervals and stamp offsets compactly (8 B each)."""

    __slots__ = ("count", "first", "intervals", "last", "offsets")

    def __init__(self) -> None:
        self.count = 0
        self.first: int | None = None
        self.last: int | None = None
        self.intervals = array("q")
        self.offsets = array("q")

    def add(self, log_time_ns: int, stamp_ns: int | None) -> None:
        if self.last is not None:
            self.intervals.append(log_time_ns - self.last)
        else:
            self.first = log_time_ns
        self.last = log_time_ns
        self.count += 1
        if stamp_ns is not None:
            self.offsets.append(stamp_ns - log_time_ns)

    def median_rate_hz(self) -> tuple[float | None, str | None]:
        """Return the median per-second message count (see :class:`TopicSummary`), or why none."""
        if self.first is None or self.last is None:
            return None, "no messages"
        duration_ns = self.last - self.first
        if duration_ns < 2 * _RATE_WINDOW_NS:
            return rate_hz(self.count, duration_ns)
        offsets = np.concatenate([[0], np.cumsum(np.frombuffer(self.intervals, dtype=np.int64))])
        window = offsets // _RATE_WINDOW_NS
        whole = int(window[-1])  # windows 0 .. whole-1 are complete; the last one is partial
        # counts of the non-empty windows only: memory follows the message count, not the
        # time span (a clock jump of years would otherwise allocate one counter per 10 s)
        ids, counts = np.unique(window[window < whole], return_counts=True)
        return median_with_zeros(counts, whole - ids.size) * _NS / _RATE_WINDOW_NS, None

    def result(self, topic: str, msgtype: str, encoding: str) -> TopicSummary:
        rate, why = self.median_rate_hz()
        return TopicSummary(
            topic=topic,
            msgtype=msgtype,
            encoding=encoding,
            count=self.count,
            median_rate_hz=rate,
            largest_gap_s=max(self.intervals) / _NS if self.intervals else None,
            first_ns=self.first,
            last_ns=self.last,
            duration_s=(self.last - self.first) / _NS
            if self.first is not None and self.last is not None
            else 0.0,
            median_stamp_offset_ms=statistics.median(self.offsets) / 1e6 if self.offsets else None,
            rate_note=why,
        )


def median_with_zeros(counts: np.ndarray, zeros: int) -> float:
    """Return the median of ``counts`` extended by ``zeros`` zero entries (not materialised)."""
    values = np.sort(counts[counts > 0])
    n = values.size + zeros
    if n == 0:
        return 0.0

    def at(i: int) -> float:
        return 0.0 if i < zeros else float(values[i - zeros])

    mid = n // 2
    return at(mid) if n % 2 else (at(mid - 1) + at(mid)) / 2.0


def container_name(recording: Recording) -> str:
    """Return a short name of the recording's container kind."""
    kind = getattr(recording, "kind", None)
    if isinstance(kind, str):
        return kind
    name = type(recording).__name__
    return {"McapRecording": "mcap", "CanLogRecording": "can log", "NmeaRecording": "nmea"}.get(
        name, name
    )


def summarize(
    recording: Recording, progress: Callable[[int], None] | None = None
) -> RecordingSummary:
    """Compute per-topic statistics in one streaming pass.

    Payloads are not decoded when the source can read header stamps from the raw bytes
    (:class:`~superlane_tools.recording.base.SupportsStampPeek`); otherwise messages are decoded.
    Memory grows by 16 bytes per message at most (intervals and stamp offsets).

    Args:
        recording: An open recording.
        progress: Called with the number of messages read so far, every
            :data:`PROGRESS_EVERY` messages and at the end.

    Returns:
        The summary, topics sorted by name; declared topics without messages have count 0.
    """
    declared = {info.topic: info for info in recording.topics()}
    stats: dict[str, _TopicStats] = {}
    kinds: dict[str, tuple[str, str]] = {
        info.topic: (info.msgtype, info.encoding) for info in declared.values()
    }
    total = 0
    if isinstance(recording, SupportsStampPeek):
        for raw in recording.raw_messages():
            stats.setdefault(raw.topic, _TopicStats()).add(
                raw.log_time_ns, recording.peek_stamp_ns(raw)
            )
            kinds.setdefault(raw.topic, (raw.msgtype, raw.encoding))
            total += 1
            if progress is not None and total % PROGRESS_EVERY == 0:
                progress(total)
    else:
        for msg in recording.messages():
            stats.setdefault(msg.topic, _TopicStats()).add(msg.log_time_ns, msg.stamp_ns)
            if msg.topic not in kinds:
                kinds[msg.topic] = (msg.msgtype, "")
            total += 1
            if progress is not None and total % PROGRESS_EVERY == 0:
                progress(total)
    if progress is not None:
        progress(total)
    topics = tuple(
        stats.get(name, _TopicStats()).result(name, *kinds[name]) for name in sorted(kinds)
    )
    firsts = [t.first_ns for t in topics if t.first_ns is not None]
    lasts = [t.last_ns for t in topics if t.last_ns is not None]
    start = min(firsts) if firsts else None
    end = max(lasts) if lasts else None
    return RecordingSummary(
        path=str(recording.path),
        container=container_name(recording),
        topics=topics,
        skipped=tuple(recording.skipped),
        message_count=total,
        start_ns=start,
        end_ns=end,
        duration_s=(end - start) / _NS if start is not None and end is not None else 0.0,
    )
