"""``slt cat`` and ``slt filter``: decoded messages as JSON lines, and trimmed copies."""

from __future__ import annotations

import base64
import re
from collections.abc import Callable, Iterator
from dataclasses import dataclass, fields, is_dataclass
from pathlib import Path
from typing import Any

import numpy as np

from superlane_tools.errors import UsageError
from superlane_tools.recording.base import Recording
from superlane_tools.recording.errors import RecordingError
from superlane_tools.recording.mcap_copy import McapCopier
from superlane_tools.recording.times import parse_time
from superlane_tools.records import Message, Skipped

MAX_INLINE_BYTES = 64
"""Byte arrays longer than this are shown as their length (``--full-bytes`` shows them)."""


def topic_matcher(include: str | None, exclude: str | None) -> Any:
    """Return ``f(topic) -> bool`` for ``--topics`` / ``--exclude`` regular expressions.

    Raises:
        UsageError: For an invalid regular expression.
    """
    try:
        inc = re.compile(include) if include else None
        exc = re.compile(exclude) if exclude else None
    except re.error as err:
        raise UsageError(f"invalid topic regular expression {err.pattern!r}: {err}") from err

    def match(topic: str) -> bool:
        return (inc is None or inc.search(topic) is not None) and (
            exc is None or exc.search(topic) is None
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
    topics: str | None = None,
    start: str | None = None,
    end: str | None = None,
) -> Iterator[Message]:
    """Yield the decoded messages of matching topics in ``[start, end)``."""
    match = topic_matcher(topics, None)
    names = [t.topic for t in rec.topics() if match(t.topic)]
    if not names:
        known = ", ".join(t.topic for t in rec.topics()) or "none"
        raise UsageError(f"no topic matches {topics!r} (topics: {known})")
    start_ns, end_ns = time_range(first_log_time(rec) if start or end else None, start, end)
    return rec.messages(topics=names, start_ns=start_ns, stop_ns=end_ns)


@dataclass(frozen=True)
class FilterResult:
    """What ``filter_recording`` wrote: messages per topic, metadata and attachments kept.

    Attributes:
        path: The output written.
        counts: Messages written per topic.
        metadata: MCAP metadata records copied (0 for bags).
        attachments: MCAP attachments copied (0 for bags).
        output_format: ``mcap``, ``ros1`` (a ``.bag``) or ``ros2`` (a bag folder).
        skipped: What could not be read from the source (damaged bag data).
    """

    path: Path
    counts: dict[str, int]
    metadata: int
    attachments: int
    output_format: str = "mcap"
    skipped: tuple[Skipped, ...] = ()


def filter_recording(
    src: Path,
    out: Path,
    topics: str | None = None,
    exclude: str | None = None,
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
    from superlane_tools.recording.bag_filter import filter_bag, is_bag, output_format

    if out.exists():
        raise RecordingError(f"{out} exists already; not overwriting a recording")
    if out.resolve() == src.resolve():
        raise UsageError("-o must differ from the input")
    match = topic_matcher(topics, exclude)

    def resolve(first: int | None) -> tuple[int | None, int | None]:
        return time_range(first, start, end)

    if not is_bag(src):
        _check_mcap(src)
        if out.suffix != ".mcap":
            raise UsageError("an MCAP filters to OUT.mcap")
        return filter_mcap(src, out, match, resolve)
    counts, skipped = filter_bag(src, out, match, resolve)
    kind = "ros1" if src.suffix == ".bag" else "ros2"
    return FilterResult(out, counts, 0, 0, output_format(kind, out), tuple(skipped))


def filter_mcap(
    src: Path,
    out: Path,
    match: Callable[[str], bool],
    resolve: Callable[[int | None], tuple[int | None, int | None]],
) -> FilterResult:
    """Copy an MCAP's matching messages in ``[start, end)`` into a new MCAP, atomically.

    Schemas, channels (with their metadata), metadata records and attachments are kept; payloads
    are copied byte for byte; chunks use the source's compression.

    Args:
        src: MCAP file.
        out: Output MCAP (not existing).
        match: ``f(topic) -> bool`` of the topics to keep.
        resolve: Turns the first log time into the ``[start, end)`` range (ns).

    Raises:
        RecordingError: If ``src`` is not a readable MCAP.
        UsageError: When nothing matches.
    """
    from mcap.exceptions import McapError
    from mcap.reader import make_reader
    from mcap.writer import CompressionType, Writer

    work = out.with_name(f".{out.name}.partial")
    counts: dict[str, int] = {}
    try:
        with src.open("rb") as fin:
            reader = make_reader(fin)
            header = reader.get_header()
            summary = reader.get_summary()
            first = (
                summary.statistics.message_start_time
                if summary is not None and summary.statistics is not None
                else None
            )
            if first is None:
                first = next((m.log_time for _, _, m in reader.iter_messages()), None)
            start_ns, end_ns = resolve(first)
            compression = "zstd"
            if summary is not None and summary.chunk_indexes:
                compression = summary.chunk_indexes[0].compression or "none"
            fin.seek(0)
            reader = make_reader(fin)
            with work.open("wb") as fout:
                writer = Writer(fout, compression=CompressionType[compression.upper()])
                writer.start(profile=header.profile, library=header.library)
                copier = McapCopier(writer)
                for schema, channel, message in reader.iter_messages(
                    starting_at=start_ns, ending_before=end_ns, log_time_order=True
                ):
                    if not match(channel.topic):
                        continue
                    copier.add(schema, channel, message)
                    counts[channel.topic] = counts.get(channel.topic, 0) + 1
                fin.seek(0)
                meta = list(make_reader(fin).iter_metadata())
                for record in meta:
                    writer.add_metadata(record.name, dict(record.metadata))
                fin.seek(0)
                attachments = list(make_reader(fin).iter_attachments())
                for a in attachments:
                    writer.add_attachment(a.create_time, a.log_time, a.name, a.media_type, a.data)
                writer.finish()  # type: ignore[no-untyped-call]
        if not counts:
            raise UsageError(NOTHING_MATCHES)
        work.replace(out)
    except (ValueError, KeyError, McapError):  # damaged: copy what a record-by-record scan reads
        work.unlink(missing_ok=True)
        return _filter_scanned(src, out, match, resolve)
    except OSError as err:
        raise RecordingError(f"cannot filter {src.name}: {err}") from err
    finally:
        if work.exists():
            work.unlink()
    return FilterResult(out, counts, len(meta), len(attachments))


NOTHING_MATCHES = "no message matches the topics and time range; nothing written"


def _check_mcap(src: Path) -> None:
    """Raise a clear error unless ``src`` starts with the MCAP magic (filter's only other input)."""
    try:
        with src.open("rb") as fin:
            magic = fin.read(8)
    except OSError as err:
        raise RecordingError(f"cannot read {src}: {err.strerror or err}") from err
    if magic != b"\x89MCAP0\r\n":
        raise RecordingError(
            f"{src.name}: slt filter reads MCAP files and ROS bags (ROS 1 .bag, ROS 2 bag "
            "folder or .db3); convert other logs with slt convert first"
        )


def _filter_scanned(
    src: Path,
    out: Path,
    match: Callable[[str], bool],
    resolve: Callable[[int | None], tuple[int | None, int | None]],
) -> FilterResult:
    """Filter a damaged MCAP: copy the matching messages a scan reads, report what was lost.

    Like ``slt recover``, messages come in the order of the file; metadata records and
    attachments are not copied (the scan reads messages only).
    """
    from superlane_tools.recording.recover import write_scanned
    from superlane_tools.recording.scan import ScannedMessage, scan_mcap

    scan = scan_mcap(src)
    first = min((m.log_time_ns for m in scan.messages()), default=None)
    start_ns, end_ns = resolve(first)

    def keep(msg: ScannedMessage) -> bool:
        t = msg.log_time_ns
        inside = (start_ns is None or t >= start_ns) and (end_ns is None or t < end_ns)
        return inside and match(msg.channel.topic)

    counts = write_scanned(scan, out, keep)
    if not counts:
        out.unlink()
        raise UsageError(NOTHING_MATCHES)
    return FilterResult(out, counts, 0, 0, "mcap", tuple(scan.skipped()))
