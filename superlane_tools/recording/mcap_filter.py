"""``slt filter`` for MCAP files: a trimmed MCAP, payloads byte for byte (damaged ones scanned)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from superlane_tools.errors import UsageError
from superlane_tools.recording._filter_types import (
    NOTHING_MATCHES,
    FilterResult,
    TimeResolve,
    TopicMatch,
    not_filterable,
)
from superlane_tools.recording.errors import RecordingError
from superlane_tools.recording.formats.mcap import MAGIC, SUFFIX
from superlane_tools.recording.mcap_copy import McapCopier

if TYPE_CHECKING:
    from superlane_tools.recording._scan_types import ScannedMessage


def filter_mcap_file(src: Path, out: Path, match: TopicMatch, resolve: TimeResolve) -> FilterResult:
    """Check that ``src`` is an MCAP and ``out`` names one, then :func:`filter_mcap` it.

    Raises:
        RecordingError: If ``src`` cannot be read or does not start with the MCAP magic.
        UsageError: If ``out`` is not ``OUT.mcap``, or nothing matches.
    """
    try:
        with src.open("rb") as fin:
            magic = fin.read(len(MAGIC))
    except OSError as err:
        raise RecordingError(f"cannot read {src}: {err.strerror or err}") from err
    if magic != MAGIC:
        raise not_filterable(src)
    if out.suffix != SUFFIX:
        raise UsageError("an MCAP filters to OUT.mcap")
    return filter_mcap(src, out, match, resolve)


def filter_mcap(
    src: Path,
    out: Path,
    match: TopicMatch,
    resolve: TimeResolve,
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


def _filter_scanned(
    src: Path,
    out: Path,
    match: TopicMatch,
    resolve: TimeResolve,
) -> FilterResult:
    """Filter a damaged MCAP: copy the matching messages a scan reads, report what was lost.

    Like ``slt recover``, messages come in the order of the file; metadata records and
    attachments are not copied (the scan reads messages only).
    """
    from superlane_tools.recording._mcap_scan import scan_mcap_file
    from superlane_tools.recording.recover import write_scanned

    scan = scan_mcap_file(src)
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
