"""``slt cat`` and ``slt filter``: decoded messages as JSON lines, and trimmed copies.

The filter itself is the reader plug-in's (:data:`~superlane_tools.recording.open.READERS`).
"""

from __future__ import annotations

import base64
import re
from collections.abc import Iterator, Sequence
from dataclasses import fields, is_dataclass
from pathlib import Path
from typing import Any

import numpy as np

from superlane_tools.errors import UsageError
from superlane_tools.recording._filter_types import FilterResult
from superlane_tools.recording.base import Recording
from superlane_tools.recording.errors import RecordingError
from superlane_tools.recording.times import parse_time
from superlane_tools.records import Message

MAX_INLINE_BYTES = 64
"""Byte arrays longer than this are shown as their length (``--full-bytes`` shows them)."""


TopicPatterns = str | Sequence[str] | None
"""One regular expression, several (a topic matching any of them), or none."""


def _listed(patterns: TopicPatterns) -> list[str]:
    return [patterns] if isinstance(patterns, str) else list(patterns or ())


def _compiled(patterns: TopicPatterns) -> list[re.Pattern[str]]:
    try:
        return [re.compile(p) for p in _listed(patterns) if p]
    except re.error as err:
        raise UsageError(f"invalid topic regular expression {err.pattern!r}: {err}") from err


def topic_matcher(include: TopicPatterns, exclude: TopicPatterns) -> Any:
    """Return ``f(topic) -> bool`` for ``--topics`` / ``--exclude`` regular expressions.

    A topic is kept when it matches any ``include`` pattern (or there is none) and no
    ``exclude`` pattern; a repeated option adds a pattern, it never replaces one.

    Raises:
        UsageError: For an invalid regular expression.
    """
    inc, exc = _compiled(include), _compiled(exclude)

    def match(topic: str) -> bool:
        return (not inc or any(p.search(topic) for p in inc)) and not any(
            p.search(topic) for p in exc
        )

    return match


def time_range(
    first_ns: int | None, start: str | None, end: str | None
) -> tuple[int | None, int | None]:
    """Resolve ``--start`` / ``--end`` (``parse_time`` syntax) to absolute ns, ``[start, end)``.

    Raises:
        UsageError: For unreadable times or an end before the start.
    """
    base = first_ns or 0
    start_ns = parse_time(start, "--start").resolve(base) if start else None
    end_ns = parse_time(end, "--end").resolve(base) if end else None
    if start_ns is not None and end_ns is not None and end_ns <= start_ns:
        raise UsageError("--end must be after --start")
    return start_ns, end_ns


def to_plain(value: Any, full_bytes: bool = False, depth: int = 0) -> Any:
    """Turn a decoded message (any source's objects) into JSON-ready data.

    Byte arrays become ``{"bytes": N}`` (or base64 with ``full_bytes``); numeric arrays become
    lists; nested messages become mappings of their fields.
    """
    if depth > 32:
        return repr(value)
    if value is None or isinstance(value, bool | int | str):
        return value
    if isinstance(value, float):
        return value if np.isfinite(value) else str(value)
    if isinstance(value, bytes | bytearray | memoryview):
        return _bytes(bytes(value), full_bytes)
    if isinstance(value, np.ndarray):
        if value.dtype == np.uint8 and value.ndim == 1:
            return _bytes(value.tobytes(), full_bytes)
        return [to_plain(v, full_bytes, depth + 1) for v in value.tolist()]
    if isinstance(value, np.generic):
        return to_plain(value.item(), full_bytes, depth + 1)
    if isinstance(value, list | tuple) and not hasattr(value, "_fields"):
        return [to_plain(v, full_bytes, depth + 1) for v in value]
    if isinstance(value, dict):
        return {str(k): to_plain(v, full_bytes, depth + 1) for k, v in value.items()}
    names = _field_names(value)
    if names is None:
        return repr(value)
    return {n: to_plain(getattr(value, n, None), full_bytes, depth + 1) for n in names}


def _bytes(data: bytes, full: bool) -> Any:
    if full or len(data) <= MAX_INLINE_BYTES:
        return {"base64": base64.b64encode(data).decode("ascii")} if full else data.hex()
    return {"bytes": len(data)}


def _field_names(value: Any) -> list[str] | None:
    if hasattr(value, "_fields"):  # NamedTuple
        return list(value._fields)
    if is_dataclass(value):
        return [f.name for f in fields(value) if not _is_constant(type(value), f.name)]
    descriptor = getattr(value, "DESCRIPTOR", None)
    if descriptor is not None and hasattr(descriptor, "fields"):  # protobuf
        return [f.name for f in descriptor.fields]
    slots = getattr(type(value), "__slots__", None)
    if slots:
        return [s for s in slots if not s.startswith("_") and not _is_constant(type(value), s)]
    if hasattr(value, "__dict__"):
        return [k for k in vars(value) if not k.startswith("_")]
    return None


def _is_constant(cls: type, name: str) -> bool:
    """Return True for a message type's constant (a plain class attribute, not a field)."""
    attr = getattr(cls, name, None)
    return attr is not None and not hasattr(attr, "__get__")


def message_record(msg: Message, full_bytes: bool = False) -> dict[str, Any]:
    """Return one message as a JSON-ready mapping."""
    return {
        "topic": msg.topic,
        "log_time_ns": msg.log_time_ns,
        "stamp_ns": msg.stamp_ns,
        "msgtype": msg.msgtype,
        "data": to_plain(msg.data, full_bytes),
    }


def first_log_time(rec: Recording) -> int | None:
    """Return the earliest log time (ns) of a recording (reads the first message)."""
    first = next(iter(rec.raw_messages()), None)
    return first.log_time_ns if first is not None else None


def cat_messages(
    rec: Recording,
    topics: TopicPatterns = None,
    start: str | None = None,
    end: str | None = None,
) -> Iterator[Message]:
    """Yield the decoded messages of matching topics in ``[start, end)``."""
    match = topic_matcher(topics, None)
    names = [t.topic for t in rec.topics() if match(t.topic)]
    if not names:
        known = ", ".join(t.topic for t in rec.topics()) or "none"
        shown = " or ".join(repr(p) for p in _listed(topics))
        raise UsageError(f"no topic matches {shown} (topics: {known})")
    start_ns, end_ns = time_range(first_log_time(rec) if start or end else None, start, end)
    return rec.messages(topics=names, start_ns=start_ns, stop_ns=end_ns)


def filter_recording(
    src: Path,
    out: Path,
    topics: TopicPatterns = None,
    exclude: TopicPatterns = None,
    start: str | None = None,
    end: str | None = None,
) -> FilterResult:
    """Write the matching messages of an MCAP or a ROS bag in ``[start, end)`` to ``out``.

    An MCAP gives an MCAP. A ROS 1 bag gives ``OUT.bag``; a ROS 2 bag (folder or ``.db3``)
    gives a ROS 2 bag folder ``OUT`` with the source's storage (sqlite3 or mcap); either gives
    an MCAP when ``out`` ends in ``.mcap``. Payloads are copied byte for byte, with their
    message definitions; the output is written atomically.

    Raises:
        RecordingError: If ``src`` is unreadable or ``out`` exists.
        UsageError: For bad regular expressions, times or output formats, or when nothing matches.
    """
    from superlane_tools.recording.open import filtering_plugin

    if out.exists():
        raise RecordingError(f"{out} exists already; not overwriting a recording")
    if out.resolve() == src.resolve():
        raise UsageError("-o must differ from the input")
    match = topic_matcher(topics, exclude)

    def resolve(first: int | None) -> tuple[int | None, int | None]:
        return time_range(first, start, end)

    plugin = filtering_plugin(src)
    assert plugin.filter is not None
    return plugin.filter(src, out, match, resolve)
