"""The one streaming pass: a recording's messages, each routed by topic to what takes it.

``slt extract`` and ``slt reprocess`` read a recording once, in log-time order, through
:func:`stream_messages`. Extract routes its topics to :class:`MessageSink` s that write its
tables (image files and ``frames.parquet``, ``camera_info.parquet``, the CAN tables,
``rtk.parquet``); reprocess routes the camera topic to the stage pipeline, whose finished frames
go to ``drive.FrameSink`` s, and its CAN, IMU and GNSS topics to in-memory collectors. A new
per-message output is a new sink, never a copy of this loop.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol

from superlane_tools.records import Message


class MessageTaker(Protocol):
    """Takes the messages of the topics routed to it (a sink, or an in-memory collector)."""

    def add(self, msg: Message) -> None:
        """Take one message."""


class MessageSink(MessageTaker, Protocol):
    """Takes messages and writes its output when closed.

    :func:`stream_messages` calls :meth:`close` once at the end: with ``ok=True`` after the last
    message, with ``ok=False`` when the pass failed (discard partial output). ``close`` returns
    the files written (none when discarded).
    """

    def close(self, ok: bool) -> list[Path]:
        """Finish (``ok``) or discard the output; return the files written."""


@dataclass(frozen=True)
class StreamPass:
    """What one pass read and wrote.

    Attributes:
        files: Per sink, in the order given, the files its ``close`` returned.
        messages: Number of messages read.
        span_ns: First and last log time of the messages read (None when none was read).
    """

    files: tuple[tuple[Path, ...], ...]
    messages: int
    span_ns: tuple[int, int] | None


def stream_messages(
    messages: Iterable[Message],
    route: Mapping[str, MessageTaker],
    sinks: Sequence[MessageSink] = (),
    progress: Callable[[int], None] | None = None,
    every: int = 256,
) -> StreamPass:
    """Read ``messages`` once, handing each to the taker of its topic; close the sinks.

    Args:
        messages: Messages in log-time order (e.g. ``recording.read_with_video(...)``).
        route: Topic -> what takes its messages; messages of other topics are read and counted,
            not taken.
        sinks: What is closed at the end, in this order (``ok=False`` on an error, which is
            then re-raised); a sink may take no topic and still write its (empty) output.
        progress: Called with the number of messages read every ``every`` messages.
        every: How often ``progress`` is called, messages.

    Returns:
        The files each sink wrote, the number of messages read and their time span.
    """
    done = 0
    first: int | None = None
    last: int | None = None
    try:
        for msg in messages:
            taker = route.get(msg.topic)
            if taker is not None:
                taker.add(msg)
            t = msg.log_time_ns
            first = t if first is None or t < first else first
            last = t if last is None or t > last else last
            done += 1
            if progress is not None and done % every == 0:
                progress(done)
    except BaseException:
        for sink in sinks:
            sink.close(False)
        raise
    files = tuple(tuple(sink.close(True)) for sink in sinks)
    span = None if first is None or last is None else (first, last)
    return StreamPass(files, done, span)
