"""Open any supported recording: a table of reader plug-ins, each chosen by the content it sees.

Every plug-in says how sure it is that a path is its format (a magic number is certain, a text
log is a vote over its first lines) and opens it. The most confident plug-in wins; on a tie the
one earlier in :data:`READERS`. Supporting a new format is one entry in that table.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, NamedTuple

from superlane_tools.recording.base import Recording
from superlane_tools.recording.errors import RecordingError

if TYPE_CHECKING:
    from mcap.decoder import DecoderFactory

MCAP_MAGIC_PREFIX = b"\x89MCAP"
ROS1_MAGIC = b"#ROSBAG V2.0"
SQLITE_MAGIC = b"SQLite format 3\x00"
CAN_SUFFIXES = {".asc", ".blf"}
TEXT_LOG_SUFFIXES = {".log", ".txt", ".nmea", ".trc", ".csv"}
MP4_BOXES = (b"moov", b"mdat", b"free", b"wide", b"skip")
"""First boxes of MP4/MOV files that do not start with ``ftyp``."""
HEAD_BYTES = 16
"""How many first bytes of a file the plug-ins see (magic numbers)."""
CERTAIN = 1 << 30
"""A plug-in's score for a magic number or a folder layout: beats any vote over text lines."""

SUPPORTED = (
    "expected an MCAP file, a ROS 1 .bag, a ROS 2 bag folder with metadata.yaml, "
    "a CAN log (candump .log, .asc, .blf), an NMEA log or a video (.mp4, .mkv, .mov, .avi); "
    "`slt convert` turns other logs (GPX, CSV) and a video with its logs into one MCAP"
)


class Probe(NamedTuple):
    """What a plug-in looks at to recognise its format.

    Attributes:
        path: The file or folder.
        is_dir: True for a folder.
        suffix: The file name's suffix in lower case (``""`` when none).
        head: The first :data:`HEAD_BYTES` bytes (empty for a folder).
    """

    path: Path
    is_dir: bool
    suffix: str
    head: bytes


@dataclass(frozen=True)
class ReaderOptions:
    """Options a plug-in may use when it opens a recording.

    Attributes:
        decoder_factories: mcap ``DecoderFactory`` objects tried before the built-in ones when
            an MCAP file's messages are decoded (as ``mcap.reader.make_reader`` takes them).
    """

    decoder_factories: tuple[DecoderFactory, ...] = ()


class ReaderPlugin(NamedTuple):
    """One supported format.

    Attributes:
        name: Short name (``mcap``, ``ros1``, ``ros2``, ``canlog``, ``nmea``).
        claims: Suffixes whose files must hold this format: a ``.bag`` that is not a bag is an
            error naming it, not a guess at another format.
        recognise: Return 0 when the probe is not this format, :data:`CERTAIN` for a magic
            number or folder layout, else the number of lines in this format among the first.
        open: Open the recording.
    """

    name: str
    claims: tuple[str, ...]
    recognise: Callable[[Probe], int]
    open: Callable[[Path, ReaderOptions], Recording]


def _sibling(module: str, *names: str) -> list[Any]:
    """Import names from a sibling source module late (it may pull in heavier libraries)."""
    try:
        mod = importlib.import_module(f"superlane_tools.recording.{module}")
        return [getattr(mod, name) for name in names]
    except (ImportError, AttributeError) as err:
        raise RecordingError(f"support for this log format is unavailable: {err}") from err


def _count(module: str, probe: str, path: Path) -> int:
    """Ask a sibling source how sure it is about ``path`` (0 when it is unavailable)."""
    try:
        (func,) = _sibling(module, probe)
    except RecordingError:
        return 0
    return int(func(path))


def _certain(found: bool) -> int:
    return CERTAIN if found else 0


def _open_mcap(path: Path, options: ReaderOptions) -> Recording:
    (cls,) = _sibling("mcap_source", "McapRecording")
    return cls(path, decoder_factories=options.decoder_factories)  # type: ignore[no-any-return]


def _open_bag(kind: str) -> Callable[[Path, ReaderOptions], Recording]:
    def open_bag(path: Path, options: ReaderOptions) -> Recording:
        del options
        (cls,) = _sibling("rosbag_source", "RosbagRecording")
        return cls(path, kind=kind)  # type: ignore[no-any-return]

    return open_bag


def _open_log(module: str, name: str) -> Callable[[Path, ReaderOptions], Recording]:
    def open_log(path: Path, options: ReaderOptions) -> Recording:
        del options
        (cls,) = _sibling(module, name)
        return cls(path)  # type: ignore[no-any-return]

    return open_log


def _is_ros2(probe: Probe) -> int:
    if probe.is_dir:
        return _certain((probe.path / "metadata.yaml").is_file())
    return _certain(probe.suffix == ".db3" and probe.head.startswith(SQLITE_MAGIC))


def _is_canlog(probe: Probe) -> int:
    if probe.suffix in CAN_SUFFIXES:
        return _certain(bool(_count("canlog_source", "looks_like_canlog", probe.path)))
    if probe.suffix == ".log":
        return _count("canlog_source", "candump_lines", probe.path)
    return 0


def _is_video(probe: Probe) -> int:
    if probe.is_dir:
        return 0
    looks_like_video, suffixes = _sibling("video_file", "looks_like_video", "VIDEO_FILE_SUFFIXES")
    if looks_like_video(probe.head):
        return CERTAIN
    # an MP4 may start with another box than ftyp
    return _certain(probe.suffix in suffixes and probe.head[4:8] in MP4_BOXES)


def _is_nmea(probe: Probe) -> int:
    if probe.is_dir or (probe.suffix and probe.suffix not in TEXT_LOG_SUFFIXES):
        return 0
    return _count("nmea_source", "nmea_lines", probe.path)


READERS: tuple[ReaderPlugin, ...] = (
    ReaderPlugin(
        "mcap", (".mcap",), lambda p: _certain(p.head.startswith(MCAP_MAGIC_PREFIX)), _open_mcap
    ),
    ReaderPlugin(
        "ros1", (".bag",), lambda p: _certain(p.head.startswith(ROS1_MAGIC)), _open_bag("ros1")
    ),
    ReaderPlugin("ros2", (".db3",), _is_ros2, _open_bag("ros2")),
    # Before NMEA: a .log file with as many candump lines as NMEA sentences is a CAN log.
    ReaderPlugin("canlog", (), _is_canlog, _open_log("canlog_source", "CanLogRecording")),
    ReaderPlugin("nmea", (), _is_nmea, _open_log("nmea_source", "NmeaRecording")),
    ReaderPlugin(
        "video",
        (".mp4", ".mkv", ".mov", ".avi", ".webm", ".m4v"),
        _is_video,
        _open_log("video_file", "VideoFileRecording"),
    ),
)
"""The reader plug-ins, most specific first (ties go to the earlier one)."""


def _probe(path: Path) -> Probe:
    """Look at ``path`` once for every plug-in; refuse what is not a file or folder."""
    if not path.exists():
        raise RecordingError(f"{path} does not exist")
    if path.is_dir():
        return Probe(path, True, "", b"")
    if not path.is_file():  # a FIFO, socket or device: reading it could block forever
        raise RecordingError(f"{path} is not a recording: not a regular file")
    try:
        with path.open("rb") as handle:
            head = handle.read(HEAD_BYTES)
    except OSError as err:
        raise RecordingError(f"cannot read {path}: {err.strerror}") from err
    if not head:
        raise RecordingError(f"{path} is not a recording: empty file (0 bytes)")
    return Probe(path, False, path.suffix.lower(), head)


def find_reader(path: str | Path) -> ReaderPlugin:
    """Return the plug-in that reads ``path``, chosen by its content (see :data:`READERS`).

    Raises:
        RecordingError: If the path is missing, is not a file or folder, or no plug-in
            recognises it (the message says what was expected).
    """
    probe = _probe(Path(path))
    best: ReaderPlugin | None = None
    best_score = 0
    for plugin in READERS:
        score = plugin.recognise(probe)
        if score > best_score:
            best, best_score = plugin, score
        if best_score >= CERTAIN:
            break
    if best is not None:
        return best
    p = probe.path
    if probe.is_dir:
        raise RecordingError(f"{p} is not a recording: a folder without metadata.yaml; {SUPPORTED}")
    if any(probe.suffix in plugin.claims for plugin in READERS):
        raise RecordingError(f"{p} is not a recording: its content is not {probe.suffix[1:]}")
    raise RecordingError(f"{p} is not a recording: unrecognised content; {SUPPORTED}")


def open_recording(
    path: str | Path, *, decoder_factories: Sequence[DecoderFactory] = ()
) -> Recording:
    """Open a recording for streaming, choosing the reader plug-in from its content.

    MCAP files and ROS 1 bags are recognised by their magic whatever their name, a folder with
    ``metadata.yaml`` is a ROS 2 bag (sqlite3 or MCAP storage, split files), a ``.db3`` file
    with the SQLite magic one ROS 2 sqlite3 storage file; ``.asc`` and ``.blf`` files open as
    CAN logs, and text logs (``.log``, ``.txt``, ``.nmea``, ``.trc``, ``.csv``, no suffix) by a
    vote over their first lines: NMEA sentences against candump lines (candump for ``.log``).
    A video file (MP4/MOV, MKV/WebM, AVI, by content) opens as a recording with one
    ``CompressedVideo`` topic (:mod:`~superlane_tools.recording.video_file`).

    Args:
        path: File or folder.
        decoder_factories: mcap decoder factories tried before the built-in ones for the
            messages of an MCAP file (other formats ignore them).

    Returns:
        The opened recording; use it as a context manager.

    Raises:
        RecordingError: If the path is missing, is not a recording, or cannot be opened.
    """
    p = Path(path)
    plugin = find_reader(p)
    return plugin.open(p, ReaderOptions(tuple(decoder_factories)))
