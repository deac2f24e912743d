"""``slt recover``: the readable messages of a damaged recording in a new, valid one.

An MCAP file is scanned record by record and written as a new, indexed MCAP; a bag is copied by
the bag filter (the reader skips what it cannot read). These are the ``recover`` capabilities of
the reader plug-ins (:data:`~superlane_tools.recording.open.READERS`).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from types import SimpleNamespace
from typing import TYPE_CHECKING, Any

from superlane_tools.errors import UsageError
from superlane_tools.recording._mcap_scan import scan_mcap_file
from superlane_tools.recording._scan_types import RecordingScan, ScannedMessage, ScanSchema
from superlane_tools.recording.errors import RecordingError
from superlane_tools.recording.mcap_copy import McapCopier
from superlane_tools.recording.writers import LIBRARY

if TYPE_CHECKING:
    from superlane_tools.recording.rosbag_source import BagKind

Recovered = tuple[dict[str, int], tuple[dict[str, Any], ...]]
"""Messages written per topic, and one entry per damaged region or kind of loss: ``what``,
``detail``, ``messages`` (None when unknown) and, where the format tells them, ``start_ns`` /
``stop_ns`` (``[start, stop)`` log times) and per-topic ``topics``."""


def recover_mcap_file(src: Path, out: Path) -> Recovered:
    """Recover an MCAP file (the MCAP plug-in's ``recover``): see :func:`recover_mcap`."""
    written, scan = recover_mcap(src, out)
    lost = tuple(
        {
            "what": loss.what,
            "detail": loss.detail,
            "messages": loss.n_messages,
            "start_ns": loss.start_ns,
            "stop_ns": loss.stop_ns,
            "topics": [part._asdict() for part in loss.topics],
        }
        for loss in scan.losses
    )
    return written, lost


def recover_bag(src: Path, out: Path, kind: BagKind) -> Recovered:
    """Recover a ROS 1 (``ros1``) or ROS 2 (``ros2``) bag: the bag plug-ins' ``recover``.

    The bag is read by the same source ``slt cat`` uses (ROS 1 reindexed by scanning when its
    index is unusable, ROS 2 sqlite3 files salvaged row by row) and copied with its connections.

    Raises:
        RecordingError: If nothing in ``src`` is readable, or ``out`` cannot be written.
    """
    from superlane_tools.recording.bag_filter import filter_bag

    try:
        written, skipped = filter_bag(src, out, lambda _topic: True, lambda _t: (None, None), kind)
    except UsageError as err:  # no topic or no message: nothing was readable
        raise RecordingError(f"{src}: no readable message; nothing written") from err
    lost = tuple(
        {"what": s.what, "detail": s.detail, "messages": s.n_items or None} for s in skipped
    )
    return written, lost


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
    scan = scan_mcap_file(src)
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
