"""`slt cat`: a recording's decoded messages, one line each, in log-time order."""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from superlane_tools.records import Skipped


@dataclass(frozen=True)
class CatParams:
    """What ``slt cat`` was asked.

    Attributes:
        recording: The recording (any format the readers open).
        topics: Only topics matching any of these regular expressions (none: every one).
        as_json: One JSON object per line instead of ``time topic [type] data``.
        start: Start time (``parse_time`` syntax), or None.
        end: End time (exclusive), or None.
        limit: Stop after this many messages, or None.
        full_bytes: Print whole byte arrays (base64), not just their length.
    """

    recording: Path
    topics: tuple[str, ...] = ()
    as_json: bool = False
    start: str | None = None
    end: str | None = None
    limit: int | None = None
    full_bytes: bool = False


@dataclass(frozen=True)
class CatResult:
    """What was printed: the message count, what the reader lost, and whether nothing was read.

    ``nothing_read`` is true when every message was asked for (no topic or time filter) and
    none could be read.
    """

    count: int
    skipped: list[Skipped]
    nothing_read: bool


def run(params: CatParams, echo: Callable[[str], None]) -> CatResult:
    """Hand each decoded message of the recording to ``echo`` as one line."""
    from superlane_tools.recording import open_recording
    from superlane_tools.recording.times import format_utc
    from superlane_tools.recording.tools import cat_messages, message_record

    count = 0
    with open_recording(params.recording) as rec:
        messages = cat_messages(rec, params.topics, params.start, params.end)
        for count, msg in enumerate(messages, start=1):
            record = message_record(msg, params.full_bytes)
            if params.as_json:
                echo(json.dumps(record, separators=(",", ":")))
            else:
                data = json.dumps(record["data"], separators=(",", ":"))
                echo(f"{format_utc(msg.log_time_ns)} {msg.topic} [{msg.msgtype}] {data}")
            if params.limit is not None and count >= params.limit:
                break
        skipped = list(rec.skipped)
    everything = not params.topics and params.start is None and params.end is None
    return CatResult(count, skipped, everything and count == 0)
