"""Scan a damaged MCAP file or ROS 1 bag record by record: what is readable, what was lost.

The scan ignores the file's index and summary and walks the data from the start, the way
``mcap recover`` and ``rosbag reindex`` do. It is the basis of ``slt recover`` (write the readable
messages into a new file) and of the damage report of ``slt info``; the MCAP and ROS 1 sources
use the same walk when a file's index is unusable.

    scan = scan_recording("cut.mcap")
    for msg in scan.messages():  # ScannedMessage(channel, log_time_ns, publish_time_ns, payload)
        msg.channel.topic, msg.channel.schema, msg.log_time_ns, msg.payload
    for loss in scan.losses:  # Loss(what, detail, byte range, time range, per-topic counts)
        ...
    scan.lost_by_topic()  # {topic: TopicLoss(topic, n_messages, start_ns, stop_ns)}

Times are integer ns since the epoch; every range is ``[start, stop)``.
"""

from __future__ import annotations

from pathlib import Path

from superlane_tools.recording._scan_types import (
    Loss,
    RecordingScan,
    ScanChannel,
    ScanFormat,
    ScannedMessage,
    ScanSchema,
    TopicLoss,
)
from superlane_tools.recording.errors import RecordingError

__all__ = [
    "Loss",
    "RecordingScan",
    "ScanChannel",
    "ScanFormat",
    "ScanSchema",
    "ScannedMessage",
    "TopicLoss",
    "scan_mcap",
    "scan_recording",
    "scan_ros1",
]


def scan_mcap(path: str | Path) -> RecordingScan:
    """Scan an MCAP file record by record (its summary and index are only checked, not used).

    A damaged summary is reported as a ``damaged summary`` loss (no messages lost with it);
    a chunk whose CRC or compression is broken as a ``corrupt chunk`` (its time range from the
    chunk header, its per-topic counts from the message indexes after it); the first record
    that cannot be read ends the scan with a ``truncated file`` loss.

    Raises:
        RecordingError: If the file cannot be read or does not start with the MCAP magic.
    """
    from superlane_tools.recording._mcap_scan import scan_mcap_file

    return scan_mcap_file(Path(path))


def scan_ros1(path: str | Path) -> RecordingScan:
    """Scan a ROS 1 bag (also a crashed recorder's ``.bag.active``) record by record.

    Connection records define the channels, chunks (uncompressed, bz2, lz4) hold the messages.
    A damaged chunk keeps the messages before the damage and is reported as a ``corrupt chunk``
    (per-topic counts from the index data records after it); a record cut short ends the scan
    with a ``truncated file`` loss after recovering the complete messages inside it.

    Raises:
        RecordingError: If the file cannot be read or does not start with the ROS 1 bag magic.
    """
    from superlane_tools.recording._ros1_scan import scan_ros1_file

    return scan_ros1_file(Path(path))


def scan_recording(path: str | Path) -> RecordingScan:
    """Scan an MCAP file or ROS 1 bag: the reader plug-in whose magic it starts with scans it.

    Raises:
        RecordingError: If the path is not a readable MCAP file or ROS 1 bag.
    """
    from superlane_tools.recording.open import read_head, scanning_plugin

    p = Path(path)
    plugin = scanning_plugin(read_head(p))
    if plugin is None or plugin.scan is None:
        raise RecordingError(f"{p} cannot be scanned: not an MCAP file or a ROS 1 bag")
    return plugin.scan(p)
