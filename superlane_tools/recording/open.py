"""Open any supported recording by looking at its path and first bytes."""

from __future__ import annotations

import importlib
from pathlib import Path
from typing import Any

from superlane_tools.recording.base import Recording
from superlane_tools.recording.errors import RecordingError

ROS1_MAGIC = b"#ROSBAG V2.0"
SQLITE_MAGIC = b"SQLite format 3\x00"
CAN_SUFFIXES = {".asc", ".blf"}
TEXT_LOG_SUFFIXES = {".log", ".txt", ".nmea", ".trc", ".csv"}

SUPPORTED = (
    "expected an MCAP file, a ROS 1 .bag, a ROS 2 bag folder with metadata.yaml, "
    "a CAN log (candump .log, .asc, .blf) or an NMEA log"
)


def _sibling(module: str, *names: str) -> list[Any]:
    """Import names from a sibling source module late (it may pull in heavier libraries)."""
    try:
        mod = importlib.import_module(f"superlane_tools.recording.{module}")
        return [getattr(mod, name) for name in names]
    except (ImportError, AttributeError) as err:
        raise RecordingError(f"support for this log format is unavailable: {err}") from err


def _looks_like(module: str, probe: str, path: Path) -> bool:
    """Ask a sibling source whether ``path`` is its format (False when it is unavailable)."""
    try:
        (func,) = _sibling(module, probe)
    except RecordingError:
        return False
    return bool(func(path))


def _count(module: str, probe: str, path: Path) -> int:
    """Ask a sibling source how many of the first lines of ``path`` are in its format."""
    try:
        (func,) = _sibling(module, probe)
    except RecordingError:
        return 0
    return int(func(path))


def open_recording(path: str | Path) -> Recording:
    """Open a recording for streaming, choosing the reader from the path and its content.

    ``.mcap`` (or MCAP magic) opens an MCAP file, ``.bag`` a ROS 1 bag, a folder with
    ``metadata.yaml`` a ROS 2 bag (sqlite3 or MCAP storage, split files), a ``.db3`` file one
    ROS 2 sqlite3 storage file; candump ``.log``, ``.asc`` and ``.blf`` files open as CAN logs and
    text logs of NMEA sentences as NMEA logs (the content is sniffed for ``.log`` and ``.txt``).

    Args:
        path: File or folder.

    Returns:
        The opened recording; use it as a context manager.

    Raises:
        RecordingError: If the path is missing, is not a recording, or cannot be opened.
    """
    p = Path(path)
    if not p.exists():
        raise RecordingError(f"{p} does not exist")
    if p.is_dir():
        if (p / "metadata.yaml").is_file():
            from superlane_tools.recording.rosbag_source import RosbagRecording

            return RosbagRecording(p, kind="ros2")
        raise RecordingError(f"{p} is not a recording: a folder without metadata.yaml; {SUPPORTED}")
    if not p.is_file():  # a FIFO, socket or device: reading it could block forever
        raise RecordingError(f"{p} is not a recording: not a regular file")
    try:
        with p.open("rb") as handle:
            head = handle.read(16)
    except OSError as err:
        raise RecordingError(f"cannot read {p}: {err.strerror}") from err
    suffix = p.suffix.lower()
    if head.startswith(b"\x89MCAP"):
        from superlane_tools.recording.mcap_source import McapRecording

        return McapRecording(p)
    if head.startswith(ROS1_MAGIC):
        from superlane_tools.recording.rosbag_source import RosbagRecording

        return RosbagRecording(p, kind="ros1")
    if suffix == ".db3" and head.startswith(SQLITE_MAGIC):
        from superlane_tools.recording.rosbag_source import RosbagRecording

        return RosbagRecording(p, kind="ros2")
    if suffix in {".mcap", ".bag", ".db3"}:
        raise RecordingError(f"{p} is not a recording: its content is not {suffix[1:]}")
    if suffix in CAN_SUFFIXES and _looks_like("canlog_source", "looks_like_canlog", p):
        (cls,) = _sibling("canlog_source", "CanLogRecording")
        return cls(p)  # type: ignore[no-any-return]
    if suffix in TEXT_LOG_SUFFIXES or not suffix:
        # Vote over the first lines: a header, one garbled or binary line does not decide.
        nmea = _count("nmea_source", "nmea_lines", p)
        candump = _count("canlog_source", "candump_lines", p) if suffix == ".log" else 0
        if nmea > candump:
            (cls,) = _sibling("nmea_source", "NmeaRecording")
            return cls(p)  # type: ignore[no-any-return]
        if candump:
            (cls,) = _sibling("canlog_source", "CanLogRecording")
            return cls(p)  # type: ignore[no-any-return]
    raise RecordingError(f"{p} is not a recording: unrecognised content; {SUPPORTED}")
