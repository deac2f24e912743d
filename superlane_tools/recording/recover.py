"""Write the readable messages of a damaged MCAP file into a new, indexed MCAP file."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from types import SimpleNamespace

from superlane_tools.recording.errors import RecordingError
from superlane_tools.recording.mcap_copy import McapCopier
from superlane_tools.recording.scan import RecordingScan, ScannedMessage, ScanSchema, scan_mcap
from superlane_tools.recording.writers import LIBRARY


def recover_mcap(src: Path, out: Path) -> tuple[dict[str, int], RecordingScan]:
    """Copy every message a scan of ``src`` reads into the MCAP ``out``, atomically.

    Schemas and channels (with their metadata) are the stored ones; payloads, log and publish
    times are copied byte for byte, in the order of the damaged file; the output is chunked
    (zstd), indexed and has a summary, like ``mcap recover`` writes.

    Args:
        src: The MCAP file, damaged or not.
        out: Output MCAP (must not exist).

    Returns:
        Messages written per topic, and the scan (its ``losses`` say what was lost).

    Raises:
        RecordingError: If ``src`` cannot be scanned or ``out`` cannot be written.
    """
    scan = scan_mcap(src)
    return write_scanned(scan, out), scan


def write_scanned(
    scan: RecordingScan, out: Path, keep: Callable[[ScannedMessage], bool] | None = None
) -> dict[str, int]:
    """Copy the readable messages of ``scan`` (those ``keep`` accepts) into the MCAP ``out``.

    Returns:
        Messages written per topic.

    Raises:
        RecordingError: If ``out`` cannot be written.
    """
    from mcap.writer import CompressionType, Writer

    schema_ids: dict[ScanSchema, int] = {}
    counts: dict[str, int] = {}
    work = out.with_name(f".{out.name}.partial")
    try:
        with work.open("xb") as handle:
            writer = Writer(handle, compression=CompressionType.ZSTD)
            writer.start(profile=_profile(scan), library=LIBRARY)
            copier = McapCopier(writer)
            for msg in scan.messages():
                if keep is not None and not keep(msg):
                    continue
                ch = msg.channel
                schema = None
                if ch.schema is not None:
                    sid = schema_ids.setdefault(ch.schema, len(schema_ids) + 1)
                    schema = SimpleNamespace(id=sid, **ch.schema._asdict())
                record = SimpleNamespace(
                    log_time=msg.log_time_ns,
                    publish_time=msg.publish_time_ns,
                    data=msg.payload,
                    sequence=0,
                )
                copier.add(schema, ch, record)
                counts[ch.topic] = counts.get(ch.topic, 0) + 1
            writer.finish()  # type: ignore[no-untyped-call]
        work.replace(out)
    except FileExistsError as err:
        raise RecordingError(f"{work} exists: another recover is writing {out.name}") from err
    except OSError as err:
        raise RecordingError(f"cannot write {out}: {err}") from err
    finally:
        work.unlink(missing_ok=True)
    return counts


def _profile(scan: RecordingScan) -> str:
    """Return the MCAP profile of the channels: ``ros1``, ``ros2`` or none."""
    encodings = {ch.message_encoding for ch in scan.channels.values()}
    if encodings == {"ros1"}:
        return "ros1"
    if encodings == {"cdr"}:
        return "ros2"
    return ""
