"""Open any supported recording: a table of reader plug-ins, the only home of format knowledge.

Every plug-in (:class:`ReaderPlugin`) says how sure it is that a path is its format (a magic
number is certain, a text log is a vote over its first lines) and opens it; the most confident
plug-in wins, on a tie the one earlier in :data:`READERS`. It also declares what else its format
can do: be scanned record by record, recovered, filtered, found in a folder by ``slt batch``,
summarised from its index alone by ``slt info``. ``scan``, ``recover``, ``filter``, batch
discovery and ``info`` ask this table (the functions at the end of this module), never a suffix
or a magic number of their own. The magic numbers, suffixes and the folder rule are spelled once,
in :mod:`superlane_tools.recording.formats`; the sources are imported inside the plug-ins'
functions, late (they may pull in heavier libraries). Supporting a new format is one module in
``formats/`` and one entry in :data:`READERS`.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, NamedTuple

from superlane_tools.recording.base import Recording
from superlane_tools.recording.errors import RecordingError
from superlane_tools.recording.formats import canlog, mcap, nmea, ros1, ros2, video
from superlane_tools.recording.formats.probe import CERTAIN, HEAD_BYTES, Probe, certain

if TYPE_CHECKING:
    from mcap.decoder import DecoderFactory

    from superlane_tools.recording._filter_types import FilterResult, TimeResolve, TopicMatch
    from superlane_tools.recording._scan_types import RecordingScan
    from superlane_tools.recording.inspect import McapFileInfo
    from superlane_tools.recording.recover import Recovered
    from superlane_tools.recording.rosbag_source import BagKind

__all__ = [
    "CERTAIN",
    "HEAD_BYTES",
    "READERS",
    "SUPPORTED",
    "Probe",
    "ReaderOptions",
    "ReaderPlugin",
    "discovered",
    "discovery_hint",
    "fast_info",
    "filtering_plugin",
    "find_reader",
    "is_recording_folder",
    "open_recording",
    "read_head",
    "recovering_plugin",
    "scanning_plugin",
]

SUPPORTED = (
    "expected an MCAP file, a ROS 1 .bag, a ROS 2 bag folder with metadata.yaml, "
    "a CAN log (candump .log, .asc, .blf), an NMEA log or a video (.mp4, .mkv, .mov, .avi); "
    "`slt convert` turns other logs (GPX, CSV) and a video with its logs into one MCAP"
)


@dataclass(frozen=True)
class ReaderOptions:
    """Options a plug-in may use when it opens a recording.

    Attributes:
        decoder_factories: mcap ``DecoderFactory`` objects tried before the built-in ones when
            an MCAP file's messages are decoded (as ``mcap.reader.make_reader`` takes them).
    """

    decoder_factories: tuple[DecoderFactory, ...] = ()


class ReaderPlugin(NamedTuple):
    """One supported format and what it can do (None: it cannot).

    Attributes:
        name: Short name (``mcap``, ``ros1``, ``ros2``, ``canlog``, ``nmea``, ``video``).
        label: What a file of it is called in messages (``MCAP file``, ``ROS 1 bag``).
        claims: Suffixes whose files must hold this format: a ``.bag`` that is not a bag is an
            error naming it, not a guess at another format; ``slt filter`` goes by them.
        recognise: Return 0 when the probe is not this format, :data:`CERTAIN` for a magic
            number or folder layout, else the number of lines in this format among the first.
        open: Open the recording.
        magic: The magic numbers its files start with (``scan`` and ``filter`` check them).
        suffixes: Every suffix its files may carry.
        folder: The folder rule: True for a folder that is one recording of this format.
        discover: True for a file or folder that ``slt batch`` takes as a recording of this
            format when it walks a folder (by name; by content only for ambiguous text logs).
        discover_hint: How discovery's messages name its recordings (``*.mcap``).
        output_suffix: The suffix of a recording of this format that ``recover`` writes
            (``""``: a folder).
        scan: Scan a damaged file record by record (``slt recover``, ``slt info``).
        recover: Write the readable messages into a new recording of this format.
        filter: Write the matching messages into a trimmed copy (``slt filter``).
        file_info: What the file's index says, read without reading a message (``slt info``'s
            fast path); None for a file without one.
    """

    name: str
    label: str
    claims: tuple[str, ...]
    recognise: Callable[[Probe], int]
    open: Callable[[Path, ReaderOptions], Recording]
    magic: tuple[bytes, ...] = ()
    suffixes: tuple[str, ...] = ()
    folder: Callable[[Path], bool] | None = None
    discover: Callable[[Path], bool] | None = None
    discover_hint: str = ""
    output_suffix: str | None = None
    scan: Callable[[Path], RecordingScan] | None = None
    recover: Callable[[Path, Path], Recovered] | None = None
    filter: Callable[[Path, Path, TopicMatch, TimeResolve], FilterResult] | None = None
    file_info: Callable[[Path], McapFileInfo | None] | None = None


@contextmanager
def _support() -> Iterator[None]:
    """Turn a missing optional library of a source into a :class:`RecordingError`."""
    try:
        yield
    except ImportError as err:
        raise RecordingError(f"support for this log format is unavailable: {err}") from err


# --- MCAP ---------------------------------------------------------------------------------


def _open_mcap(path: Path, options: ReaderOptions) -> Recording:
    with _support():
        from superlane_tools.recording.mcap_source import McapRecording

    return McapRecording(path, decoder_factories=options.decoder_factories)


def _scan_mcap(path: Path) -> RecordingScan:
    from superlane_tools.recording._mcap_scan import scan_mcap_file

    return scan_mcap_file(path)


def _recover_mcap(src: Path, out: Path) -> Recovered:
    from superlane_tools.recording.recover import recover_mcap_file

    return recover_mcap_file(src, out)


def _filter_mcap(src: Path, out: Path, match: TopicMatch, resolve: TimeResolve) -> FilterResult:
    from superlane_tools.recording.mcap_filter import filter_mcap_file

    return filter_mcap_file(src, out, match, resolve)


def _mcap_file_info(path: Path) -> McapFileInfo | None:
    from superlane_tools.recording.inspect import mcap_file_info

    return mcap_file_info(path)


# --- ROS 1 and ROS 2 bags -------------------------------------------------------------------


def _open_bag(kind: BagKind) -> Callable[[Path, ReaderOptions], Recording]:
    def open_bag(path: Path, options: ReaderOptions) -> Recording:
        del options
        with _support():
            from superlane_tools.recording.rosbag_source import RosbagRecording

        return RosbagRecording(path, kind=kind)

    return open_bag


def _scan_ros1(path: Path) -> RecordingScan:
    from superlane_tools.recording._ros1_scan import scan_ros1_file

    return scan_ros1_file(path)


def _recover_bag(kind: BagKind) -> Callable[[Path, Path], Recovered]:
    def recover_bag(src: Path, out: Path) -> Recovered:
        from superlane_tools.recording.recover import recover_bag

        return recover_bag(src, out, kind)

    return recover_bag


def _filter_bag(kind: BagKind) -> Callable[[Path, Path, TopicMatch, TimeResolve], FilterResult]:
    def filter_bag(src: Path, out: Path, match: TopicMatch, resolve: TimeResolve) -> FilterResult:
        from superlane_tools.recording.bag_filter import filter_bag_file

        return filter_bag_file(src, out, match, resolve, kind)

    return filter_bag


def _named(suffix: str) -> Callable[[Path], bool]:
    """Return a discovery rule: a file whose suffix (any case) is ``suffix``."""

    def named(path: Path) -> bool:
        return path.is_file() and path.suffix.lower() == suffix

    return named


# --- CAN and NMEA logs, video files ---------------------------------------------------------


def _open_canlog(path: Path, options: ReaderOptions) -> Recording:
    del options
    with _support():
        from superlane_tools.recording.canlog_source import CanLogRecording

    return CanLogRecording(path)


def _open_nmea(path: Path, options: ReaderOptions) -> Recording:
    del options
    with _support():
        from superlane_tools.recording.nmea_source import NmeaRecording

    return NmeaRecording(path)


def _open_video(path: Path, options: ReaderOptions) -> Recording:
    del options
    with _support():
        from superlane_tools.recording.video_file import VideoFileRecording

    return VideoFileRecording(path)


def _is_canlog(probe: Probe) -> int:
    try:
        from superlane_tools.recording.canlog_source import candump_lines, looks_like_canlog
    except ImportError:
        return 0
    if probe.suffix in canlog.VECTOR_SUFFIXES:
        return certain(looks_like_canlog(probe.path))
    if probe.suffix == canlog.CANDUMP_SUFFIX:
        return candump_lines(probe.path)
    return 0


def _discover_canlog(path: Path) -> bool:
    suffix = path.suffix.lower()
    if suffix in canlog.VECTOR_SUFFIXES:
        return path.is_file()
    if suffix == canlog.CANDUMP_SUFFIX:  # a .log file is a CAN log only by its content
        from superlane_tools.recording.canlog_source import looks_like_canlog

        return looks_like_canlog(path)
    return False


def _is_nmea(probe: Probe) -> int:
    if probe.is_dir or (probe.suffix and probe.suffix not in nmea.TEXT_LOG_SUFFIXES):
        return 0
    try:
        from superlane_tools.recording.nmea_source import nmea_lines
    except ImportError:
        return 0
    return nmea_lines(probe.path)


READERS: tuple[ReaderPlugin, ...] = (
    ReaderPlugin(
        "mcap",
        mcap.LABEL,
        (mcap.SUFFIX,),
        mcap.recognise,
        _open_mcap,
        magic=(mcap.MAGIC,),
        suffixes=(mcap.SUFFIX,),
        discover=_named(mcap.SUFFIX),
        discover_hint=f"*{mcap.SUFFIX}",
        output_suffix=mcap.SUFFIX,
        scan=_scan_mcap,
        recover=_recover_mcap,
        filter=_filter_mcap,
        file_info=_mcap_file_info,
    ),
    ReaderPlugin(
        "ros1",
        ros1.LABEL,
        (ros1.SUFFIX,),
        ros1.recognise,
        _open_bag("ros1"),
        magic=(ros1.MAGIC,),
        suffixes=(ros1.SUFFIX,),
        discover=_named(ros1.SUFFIX),
        discover_hint=f"*{ros1.SUFFIX}",
        output_suffix=ros1.SUFFIX,
        scan=_scan_ros1,
        recover=_recover_bag("ros1"),
        filter=_filter_bag("ros1"),
    ),
    ReaderPlugin(
        "ros2",
        ros2.LABEL,
        (ros2.DB3_SUFFIX,),
        ros2.recognise,
        _open_bag("ros2"),
        magic=(ros2.SQLITE_MAGIC,),
        suffixes=(ros2.DB3_SUFFIX,),
        folder=ros2.is_bag_folder,
        discover=ros2.is_bag_folder,
        discover_hint=f"{ros2.LABEL}s",
        output_suffix="",
        recover=_recover_bag("ros2"),
        filter=_filter_bag("ros2"),
    ),
    # Before NMEA: a .log file with as many candump lines as NMEA sentences is a CAN log.
    ReaderPlugin(
        "canlog",
        canlog.LABEL,
        (),
        _is_canlog,
        _open_canlog,
        magic=(canlog.BLF_MAGIC,),
        suffixes=canlog.SUFFIXES,
        discover=_discover_canlog,
        discover_hint=f"{canlog.LABEL}s",
    ),
    ReaderPlugin(
        "nmea", nmea.LABEL, (), _is_nmea, _open_nmea, suffixes=tuple(sorted(nmea.TEXT_LOG_SUFFIXES))
    ),
    ReaderPlugin(
        "video",
        video.LABEL,
        tuple(sorted(video.SUFFIXES)),
        video.recognise,
        _open_video,
        magic=video.MAGIC,
        suffixes=tuple(sorted(video.SUFFIXES)),
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
        raise RecordingError(f"{p} is not a recording: {ros2.NOT_A_BAG_FOLDER}; {SUPPORTED}")
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


# --- what the commands ask the table --------------------------------------------------------


def read_head(path: Path) -> bytes:
    """Return the first :data:`HEAD_BYTES` bytes of a file (for :func:`scanning_plugin` & co).

    Raises:
        RecordingError: If the file cannot be read.
    """
    try:
        with path.open("rb") as handle:
            return handle.read(HEAD_BYTES)
    except OSError as err:
        raise RecordingError(f"cannot read {path}: {err.strerror or err}") from err


def _has_magic(plugin: ReaderPlugin, head: bytes) -> bool:
    return any(head.startswith(magic) for magic in plugin.magic)


def scanning_plugin(head: bytes) -> ReaderPlugin | None:
    """Return the plug-in that scans a file starting with ``head`` (its full magic), if any."""
    return next((p for p in READERS if p.scan is not None and _has_magic(p, head)), None)


def recovering_plugin(src: Path) -> ReaderPlugin | None:
    """Return the plug-in that recovers ``src`` (a folder, or a file by its content), if any.

    Raises:
        RecordingError: If the file cannot be read.
    """
    if src.is_dir():
        probe = Probe(src, True, "", b"")
    else:
        probe = Probe(src, False, src.suffix.lower(), read_head(src))
    capable = (p for p in READERS if p.recover is not None)
    return next((p for p in capable if p.recognise(probe) >= CERTAIN), None)


def filtering_plugin(src: Path) -> ReaderPlugin:
    """Return the plug-in that filters ``src``: named by suffix or folder layout, else by magic.

    Raises:
        RecordingError: If ``src`` cannot be read or no plug-in filters it.
    """
    from superlane_tools.recording._filter_types import not_filterable

    capable = [p for p in READERS if p.filter is not None]
    for plugin in capable:
        if src.suffix in plugin.claims or (plugin.folder is not None and plugin.folder(src)):
            return plugin
    head = read_head(src)
    found = next((p for p in capable if _has_magic(p, head)), None)
    if found is None:
        raise not_filterable(src)
    return found


def is_recording_folder(path: Path) -> bool:
    """Return True when ``path`` is a folder that one plug-in reads as one recording."""
    return any(p.folder is not None and p.folder(path) for p in READERS)


def discovered(path: Path) -> bool:
    """Return True when ``slt batch`` takes ``path``, met while walking a folder, as a recording."""
    return any(p.discover is not None and p.discover(path) for p in READERS)


def discovery_hint() -> str:
    """Name what discovery finds, for messages (``*.mcap, *.bag, ROS 2 bags, CAN logs``)."""
    return ", ".join(p.discover_hint for p in READERS if p.discover_hint)


def fast_info(path: Path) -> McapFileInfo | None:
    """Return what a recording's index says without reading a message (``slt info``), if any."""
    for plugin in READERS:
        if plugin.file_info is not None:
            info = plugin.file_info(path)
            if info is not None:
                return info
    return None
