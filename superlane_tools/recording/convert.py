"""Turn what engineers have (a dashcam video, GNSS/CAN/signal logs) into one MCAP recording.

Inputs and what they become (ROS 2 CDR in MCAP, which ``slt`` and Foxglove both read):

- MP4/MKV/MOV/AVI video -> ``foxglove_msgs/msg/CompressedVideo`` on ``/camera/video``. H.264 and
  H.265 packets are copied (turned into Annex B by FFmpeg's ``*_mp4toannexb`` filters); a stream
  with B-frames, or another codec, is re-encoded to H.264, since ``CompressedVideo`` has no
  B-frames. Frame times come from the container (``pts``) or from a start time plus ``fps``.
- NMEA 0183 (GGA/RMC) and GPX (``gpxpy``) -> ``sensor_msgs/msg/NavSatFix`` on ``/gnss/fix``.
- candump / ASC / BLF / TRC CAN logs (python-can) -> ``can_msgs/msg/Frame`` on ``/can/<channel>``.
- CSV with a time column and numeric columns -> ``std_msgs/msg/Float64`` per column on
  ``/signals/<column>`` (plottable in Foxglove).

Time alignment is explicit: every input's own clock plus its ``offset`` (seconds) gives the
recording's time; the chosen alignment is written to the ``slt_convert`` metadata record.
"""

from __future__ import annotations

import contextlib
import heapq
import math
import re
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

from superlane_tools.camera.metadata import METADATA_NAME as METADATA_CAMERA
from superlane_tools.camera.metadata import camera_metadata
from superlane_tools.errors import UsageError
from superlane_tools.recording import messages as msgs
from superlane_tools.recording.base import SkipLog
from superlane_tools.recording.errors import RecordingError
from superlane_tools.recording.formats import canlog, nmea, video
from superlane_tools.recording.times import format_utc, parse_time
from superlane_tools.recording.typestore import COMPRESSED_VIDEO_MSGTYPE
from superlane_tools.records import Skipped

if TYPE_CHECKING:
    from superlane_tools.camera.model import CameraModel
    from superlane_tools.recording.writers import RecordingWriter

InputKind = Literal["video", "nmea", "gpx", "can", "csv"]
VIDEO_SUFFIXES = video.SUFFIXES | video.RAW_SUFFIXES
CAN_SUFFIXES = frozenset({*canlog.VECTOR_SUFFIXES, *canlog.CONVERT_SUFFIXES})
METADATA_NAME = "slt_convert"
VIDEO_TOPIC = "/camera/video"
CAMERA_INFO_TOPIC = "/camera/camera_info"
CAMERA_FRAME = "camera"
VEHICLE_FRAME = "base_link"
FIX_TOPIC = "/gnss/fix"
_NS = 1_000_000_000
_TIME_COLUMNS = ("time_ns", "t_ns", "timestamp_ns", "time", "t", "timestamp", "time_s", "t_s")
_SAFE = re.compile(r"[^A-Za-z0-9_]+")
_NAN_TEXT = ("nan", "na", "n/a", "null", "none", "-")
"""Cell texts taken as 'no value' in a CSV signal column, not as damage."""


@dataclass(frozen=True)
class ConvertInput:
    """One input file.

    Attributes:
        path: The file.
        kind: ``video``, ``nmea``, ``gpx``, ``can`` or ``csv`` (None: from the name/content).
        offset_s: Seconds added to this file's times to put them on the recording's clock.
    """

    path: Path
    kind: InputKind | None = None
    offset_s: float = 0.0


@dataclass(frozen=True)
class ConvertConfig:
    """How to convert.

    Attributes:
        video_start: Time of the video's first frame (``parse_time`` syntax, absolute); None:
            the container's ``creation_time``, else the Unix epoch (the times then only say
            seconds into the video).
        fps: Frame rate for frame times ``start + i / fps``; None: the container's times.
        reencode_crf: CRF of the H.264 re-encode (used only when packets cannot be copied).
        camera: Camera profile name or YAML of the video's camera; when given, every frame gets
            a ``sensor_msgs/msg/CameraInfo`` (intrinsics scaled to the video size) and the file
            an ``slt_camera`` metadata record (extrinsics), so ``--camera auto`` finds both.
    """

    video_start: str | None = None
    fps: float | None = None
    reencode_crf: int = 20
    camera: str | None = None


@dataclass
class ConvertResult:
    """What was written: message counts per topic, the alignment, notes, and what was skipped."""

    path: Path
    counts: dict[str, int] = field(default_factory=dict)
    alignment: dict[str, str] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    skipped: list[Skipped] = field(default_factory=list)


def input_kind(path: Path) -> InputKind:
    """Return what a file holds, from its suffix (and content for text logs).

    Raises:
        RecordingError: If it is none of the convertible kinds.
    """
    suffix = path.suffix.lower()
    if suffix in VIDEO_SUFFIXES:
        return "video"
    if suffix == ".gpx":
        return "gpx"
    if suffix == ".csv":
        return "csv"
    if suffix in CAN_SUFFIXES:
        return "can"
    if suffix in nmea.TEXT_LOG_SUFFIXES or not suffix:  # .csv and .trc are taken above
        from superlane_tools.recording.canlog_source import looks_like_canlog
        from superlane_tools.recording.nmea_source import looks_like_nmea

        if looks_like_nmea(path):
            return "nmea"
        if looks_like_canlog(path):
            return "can"
    raise RecordingError(
        f"{path.name}: cannot tell what this file is (video .mp4/.mkv, NMEA, .gpx, "
        "candump/.asc/.blf CAN log, .csv); name the kind with --kind"
    )


# ---------------------------------------------------------------------------------------------
# Each source yields (time_ns, topic, msgtype, message) in time order.
Item = tuple[int, str, str, Any]


def _video_items(
    path: Path, config: ConvertConfig, offset_ns: int, result: ConvertResult
) -> Iterator[Item]:
    import av

    try:
        container = av.open(str(path))
    except (av.FFmpegError, OSError) as err:
        raise RecordingError(f"{path.name}: cannot open the video: {err}") from err
    with container:
        if not container.streams.video:
            raise RecordingError(f"{path.name}: has no video stream")
        stream = container.streams.video[0]
        start_ns, source = _video_start(container, config)
        result.alignment[f"{path.name}.start"] = f"{format_utc(start_ns + offset_ns)} ({source})"
        codec = stream.codec_context.name
        fmt = {"h264": "h264", "hevc": "h265"}.get(codec)
        copy = fmt is not None and not _has_reordering(path)
        result.notes.append(
            f"{path.name}: {codec} packets copied"
            if copy
            else f"{path.name}: {codec} re-encoded to H.264 (B-frames or codec not streamable)"
        )
        tb = stream.time_base
        size = (int(stream.codec_context.width), int(stream.codec_context.height))
        index = 0
        first_pts: int | None = None

        def frame_time(pts: int | None) -> int:
            nonlocal first_pts
            if config.fps is not None or pts is None or tb is None:
                rate = config.fps or float(stream.average_rate or 30)
                return start_ns + offset_ns + round(index * _NS / rate)
            if first_pts is None:
                first_pts = pts
            return start_ns + offset_ns + round(float((pts - first_pts) * tb) * _NS)

        if copy:
            assert fmt is not None
            bsf = av.bitstream.BitStreamFilterContext(f"{codec}_mp4toannexb", stream)
            for packet in container.demux(stream):
                for out in bsf.filter(packet if packet.size else None):
                    t = frame_time(out.pts)
                    index += 1
                    yield t, VIDEO_TOPIC, COMPRESSED_VIDEO_MSGTYPE, (fmt, bytes(out), size)
            return
        from superlane_tools.recording.video import VideoEncoder

        encoder: VideoEncoder | None = None
        for frame in container.decode(stream):
            image: np.ndarray = frame.to_ndarray(format="bgr24")
            height, width = image.shape[:2]
            if encoder is None:
                rate = config.fps or float(stream.average_rate or 30)
                encoder = VideoEncoder(
                    "h264", width - width % 2, height - height % 2, rate, config.reencode_crf,
                    max(1, round(rate)),
                )  # fmt: skip
            t = frame_time(frame.pts)
            index += 1
            unit = encoder.encode(image[: height - height % 2, : width - width % 2])
            yield t, VIDEO_TOPIC, COMPRESSED_VIDEO_MSGTYPE, ("h264", unit, encoder.size)


def _camera_info(camera: Any, t_ns: int, size: tuple[int, int]) -> Any:
    k = camera.intrinsics
    if (k.width, k.height) != size:
        k = k.scaled(*size)
    return msgs.camera_info(t_ns, CAMERA_FRAME, k.width, k.height, k.matrix, list(k.dist))


def _has_reordering(path: Path) -> bool:
    """Return True when packets come out of presentation order (B-frames)."""
    import av

    with av.open(str(path)) as container:
        stream = container.streams.video[0]
        last = None
        for packet in container.demux(stream):
            if packet.pts is None:
                continue
            if last is not None and packet.pts < last:
                return True
            last = packet.pts
    return False


def _video_start(container: Any, config: ConvertConfig) -> tuple[int, str]:
    if config.video_start is not None:
        spec = parse_time(config.video_start, "--video-start")
        if not spec.absolute:
            raise RecordingError("--video-start must be an absolute time (ISO 8601 or epoch ns)")
        return spec.ns, "--video-start"
    created = container.metadata.get("creation_time")
    if created:
        try:
            return parse_time(str(created)).ns, "container creation_time"
        except Exception:  # an unreadable tag: fall back to the epoch
            pass
    return 0, "no start time known: seconds into the video"


def _fix_items(path: Path, offset_ns: int, result: ConvertResult) -> Iterator[Item]:
    from superlane_tools.recording.nmea_source import NmeaRecording

    with NmeaRecording(path) as rec, _reporting_skips(rec, result):
        for m in rec.messages():
            d = m.data
            cov = d.position_covariance if d.position_covariance_type else None
            fix = msgs.navsatfix(
                m.log_time_ns + offset_ns,
                "gnss",
                d.latitude,
                d.longitude,
                0.0 if math.isnan(d.altitude) else d.altitude,
                d.status.status,
                cov,
            )
            yield m.log_time_ns + offset_ns, FIX_TOPIC, "sensor_msgs/msg/NavSatFix", fix


def _gpx_items(path: Path, offset_ns: int, result: ConvertResult) -> Iterator[Item]:
    import gpxpy

    try:
        text = path.read_text(encoding="utf-8", errors="replace")
    except OSError as err:
        raise RecordingError(f"{path.name}: cannot read: {err.strerror}") from err
    try:
        gpx = gpxpy.parse(text)
        points = _gpx_points(gpx)
    except Exception as err:  # gpxpy raises its own and XML errors: salvage point by point
        reason = str(err).strip().splitlines()[0] if str(err).strip() else type(err).__name__
        points, bad = _salvage_gpx_points(text)
        if not points:
            raise RecordingError(f"{path.name}: not a readable GPX file: {reason}") from err
        # one line: how many points were lost, or (junk between points) that the XML was damaged
        what = "bad GPX point" if bad else "damaged GPX file"
        result.skipped.append(Skipped(what, f"{path.name}: {reason}", bad))
    timed = sorted((p for p in points if p.time is not None), key=lambda p: p.time)
    if not timed:
        raise RecordingError(f"{path.name}: no GPX point has a time")
    if len(timed) < len(points):
        result.skipped.append(
            Skipped("GPX point without time", path.name, len(points) - len(timed))
        )
    for p in timed:
        t = parse_time(p.time.isoformat()).ns + offset_ns
        alt = float(p.elevation) if p.elevation is not None else 0.0
        fix = msgs.navsatfix(t, "gnss", p.latitude, p.longitude, alt, 0)
        yield t, FIX_TOPIC, "sensor_msgs/msg/NavSatFix", fix


def _gpx_points(gpx: Any) -> list[Any]:
    points: list[Any] = [p for track in gpx.tracks for seg in track.segments for p in seg.points]
    return points + list(gpx.waypoints) + [p for route in gpx.routes for p in route.points]


_GPX_POINT = re.compile(r"<(trkpt|rtept|wpt)\b.*?</\1\s*>", re.DOTALL)
_GPX_OPEN = re.compile(r"<(?:trkpt|rtept|wpt)\b")
_GPX_WRAP = {
    "trkpt": ("<trk><trkseg>", "</trkseg></trk>"),
    "rtept": ("<rte>", "</rte>"),
    "wpt": ("", ""),
}


def _salvage_gpx_points(text: str) -> tuple[list[Any], int]:
    """Read the points of a GPX file that is not well-formed XML (binary junk, a cut file).

    Every ``<trkpt>``, ``<rtept>`` and ``<wpt>`` element is parsed on its own by gpxpy, in a
    minimal GPX document; returns the points read and how many elements did not parse (an
    element opened but never closed, as at a cut, included).
    """
    import gpxpy

    points: list[Any] = []
    elements = list(_GPX_POINT.finditer(text))
    bad = max(0, len(_GPX_OPEN.findall(text)) - len(elements))
    for match in elements:
        head, tail = _GPX_WRAP[match[1]]
        doc = (
            '<gpx version="1.1" xmlns="http://www.topografix.com/GPX/1/1">'
            f"{head}{match[0]}{tail}</gpx>"
        )
        try:
            points += _gpx_points(gpxpy.parse(doc))
        except Exception:  # gpxpy/XML errors: this point is damaged
            bad += 1
    return points, bad


def _can_items(path: Path, offset_ns: int, result: ConvertResult) -> Iterator[Item]:
    from superlane_tools.recording.canlog_source import CanLogRecording

    with CanLogRecording(path) as rec, _reporting_skips(rec, result):
        for m in rec.messages():
            f = m.data
            if f.is_error or f.is_rtr or len(f.data) > 8:
                result.notes.append(f"{path.name}: error/RTR/CAN FD frames are not written")
                continue
            topic = "/can/" + (_SAFE.sub("_", m.topic).strip("_") or "raw")
            t = m.log_time_ns + offset_ns
            yield t, topic, "can_msgs/msg/Frame", msgs.can_frame(t, f.id, f.data, f.is_extended)


def _csv_items(path: Path, offset_ns: int, result: ConvertResult) -> Iterator[Item]:
    import pandas as pd

    bad_lines: list[list[str]] = []

    def bad_line(fields: list[str]) -> None:  # wrong field count: two rows run together, junk
        bad_lines.append(fields)

    try:
        table = pd.read_csv(
            path, dtype=str, keep_default_na=False, encoding_errors="replace", engine="python",
            on_bad_lines=bad_line,
        )  # fmt: skip
    except Exception as err:  # pandas parser errors
        reason = str(err).strip().splitlines()[0] if str(err).strip() else type(err).__name__
        raise RecordingError(f"{path.name}: not a readable CSV: {reason}") from err
    lower = {str(c).strip().lower(): c for c in table.columns}
    time_col = next((lower[n] for n in _TIME_COLUMNS if n in lower), None)
    if time_col is None:
        raise RecordingError(
            f"{path.name}: no time column (one of {', '.join(_TIME_COLUMNS)}) in the CSV"
        )
    times, bad_times = _csv_times(table[time_col], str(time_col))
    values, bad_values = _csv_signals(table.drop(columns=[time_col]))
    if not values:
        raise RecordingError(f"{path.name}: no numeric signal columns besides {time_col}")
    skips = SkipLog()
    if bad_lines:
        skips.add("bad CSV line", f"{path.name}: {bad_lines[0]!r:.60}", len(bad_lines))
    for rows, what in ((bad_times, "bad CSV time"), (bad_values, "bad CSV value")):
        if rows:
            skips.add(what, f"{path.name}: first at data row {rows[0] + 1}", len(rows))
    result.skipped.extend(skips.items())
    cls = _float64_cls()
    topics = {c: "/signals/" + (_SAFE.sub("_", str(c)).strip("_") or "value") for c in values}
    for row in np.flatnonzero(times >= 0):
        t = int(times[row]) + offset_ns
        for c, column in values.items():
            value = float(column[row])
            if math.isfinite(value):
                yield t, topics[c], "std_msgs/msg/Float64", cls(data=value)


def _csv_signals(table: Any) -> tuple[dict[Any, np.ndarray], list[int]]:
    """Return the numeric columns (as floats, NaN where empty) and the rows of bad cells.

    A column is a signal when most of its filled cells are numbers; its other filled cells
    (binary junk, a garbled number) are bad values, skipped and counted per cell.
    """
    import pandas as pd

    columns: dict[Any, np.ndarray] = {}
    bad: list[int] = []
    for c in table.columns:
        text = table[c].str.strip()
        filled = text != ""
        numbers = pd.to_numeric(text.where(filled), errors="coerce").to_numpy(dtype=np.float64)
        wrong = filled.to_numpy() & np.isnan(numbers) & ~text.str.lower().isin(_NAN_TEXT)
        if filled.sum() and wrong.sum() * 2 < filled.sum():
            columns[c] = numbers
            bad.extend(np.flatnonzero(wrong).tolist())
    return columns, sorted(set(bad))


def _csv_times(column: Any, name: str) -> tuple[np.ndarray, list[int]]:
    """Return each row's time in ns (-1 where unreadable) and the unreadable rows.

    Raises:
        RecordingError: If no row has a readable time.
    """
    import pandas as pd

    text = column.str.strip()
    numbers = pd.to_numeric(text, errors="coerce").to_numpy(dtype=np.float64)
    times = np.full(len(text), -1, dtype=np.int64)
    if np.isfinite(numbers).sum() * 2 > len(numbers):  # numeric times: seconds or ns
        ok = np.isfinite(numbers) & (numbers >= 0)
        in_ns = name.lower().endswith("_ns") or (ok.any() and np.median(numbers[ok]) > 1e15)
        scaled = numbers if in_ns else numbers * _NS
        ok &= scaled < 2**63
        times[ok] = np.round(scaled[ok]).astype(np.int64)
    else:
        for row, value in enumerate(text):
            try:
                times[row] = parse_time(value, name).ns
            except (UsageError, RecordingError, ValueError):
                continue
    bad = np.flatnonzero(times < 0).tolist()
    if len(bad) == len(times):
        raise RecordingError(f"{name}: no readable time in the CSV's time column")
    return times, bad


@contextlib.contextmanager
def _reporting_skips(rec: Any, result: ConvertResult) -> Iterator[None]:
    """Add what a log reader skipped to ``result`` once its messages have been read."""
    try:
        yield
    finally:
        result.skipped.extend(rec.skipped)


def _float64_cls() -> Any:
    from superlane_tools.recording.typestore import default_typestore

    return default_typestore().types["std_msgs/msg/Float64"]


def convert(
    inputs: Sequence[ConvertInput],
    out: str | Path,
    config: ConvertConfig | None = None,
    command: str = "",
) -> ConvertResult:
    """Convert the inputs into one new MCAP file, written atomically.

    Args:
        inputs: The files; at most one video.
        out: Output ``.mcap`` path (must not exist).
        config: Video timing options.
        command: Command line for the metadata record.

    Returns:
        Counts per topic, the time alignment, notes, and what was skipped in the inputs (bad
        NMEA checksums, unparsable log lines).

    Raises:
        RecordingError: For unreadable inputs, two videos, or an existing output.
    """
    from superlane_tools.recording.writers import open_writer

    cfg = config or ConvertConfig()
    if not inputs:
        raise RecordingError("nothing to convert: pass at least one input file")
    result = ConvertResult(Path(out))
    sources: list[Iterator[Item]] = []
    kinds: list[InputKind] = []
    for item in inputs:
        kind = _checked_kind(item)
        kinds.append(kind)
        offset_ns = round(item.offset_s * _NS)
        result.alignment[f"{item.path.name}.kind"] = kind
        result.alignment[f"{item.path.name}.offset_ns"] = str(offset_ns)
        sources.append(_items(kind, item.path, cfg, offset_ns, result))
    if kinds.count("video") > 1:
        raise RecordingError("one video per recording: convert each video on its own")
    result.alignment["clock"] = (
        "shared clock (no offsets)"
        if all(i.offset_s == 0 for i in inputs)
        else "each input's clock plus its --offset"
    )
    camera = _video_camera(cfg, kinds)
    with open_writer(out, "mcap", compression="none" if "video" in kinds else "zstd") as writer:
        if not _write_merged(writer, sources, camera, result):
            raise RecordingError("the inputs hold no messages to write")
        writer.add_metadata(
            METADATA_NAME,
            {
                "command": command,
                **result.alignment,
                "notes": "; ".join(dict.fromkeys(result.notes)),
            },
        )
    result.notes = list(dict.fromkeys(result.notes))
    return result


def _checked_kind(item: ConvertInput) -> InputKind:
    """Return what an input holds, after checking that it is a non-empty file."""
    if item.path.is_dir():
        raise RecordingError(
            f"{item.path} is a folder; convert takes files (video, NMEA, GPX, CAN log, CSV)"
        )
    if not item.path.is_file():
        raise RecordingError(f"input not found: {item.path}")
    if item.path.stat().st_size == 0:
        raise RecordingError(f"{item.path}: empty file (0 bytes)")
    return item.kind or input_kind(item.path)


def _items(
    kind: InputKind, path: Path, cfg: ConvertConfig, offset_ns: int, result: ConvertResult
) -> Iterator[Item]:
    """The time-ordered items of one input of ``kind`` (read when first iterated)."""
    if kind == "video":
        return _video_items(path, cfg, offset_ns, result)
    if kind == "nmea":
        return _fix_items(path, offset_ns, result)
    if kind == "gpx":
        return _gpx_items(path, offset_ns, result)
    if kind == "can":
        return _can_items(path, offset_ns, result)
    return _csv_items(path, offset_ns, result)


def _video_camera(cfg: ConvertConfig, kinds: list[InputKind]) -> CameraModel | None:
    """The camera of ``--camera``, which needs a video input; None without the option."""
    if cfg.camera is None:
        return None
    from superlane_tools.camera import load_camera

    if "video" not in kinds:
        raise RecordingError("--camera describes a video's camera: give a video input")
    return load_camera(cfg.camera)


def _write_merged(
    writer: RecordingWriter,
    sources: list[Iterator[Item]],
    camera: CameraModel | None,
    result: ConvertResult,
) -> dict[str, str]:
    """Write the inputs' items in time order, counting them; return the topics and types.

    A video frame becomes a ``CompressedVideo`` message, with its camera info when a camera
    is given (the camera's topic and metadata record come with the first frame).
    """
    topics: dict[str, str] = {}
    for t, topic, msgtype, payload in heapq.merge(*sources, key=lambda x: x[0]):
        if topic not in topics:
            writer.add_topic(topic, msgtype)
            topics[topic] = msgtype
        message = payload
        if msgtype == COMPRESSED_VIDEO_MSGTYPE:
            message = msgs.compressed_video(t, CAMERA_FRAME, payload[0], payload[1])
            if camera is not None:
                info = _camera_info(camera, t, payload[2])
                if CAMERA_INFO_TOPIC not in topics:
                    writer.add_topic(CAMERA_INFO_TOPIC, "sensor_msgs/msg/CameraInfo")
                    topics[CAMERA_INFO_TOPIC] = "sensor_msgs/msg/CameraInfo"
                    writer.add_metadata(
                        METADATA_CAMERA, camera_metadata(camera, VEHICLE_FRAME, CAMERA_FRAME)
                    )
                writer.write(CAMERA_INFO_TOPIC, t, info)
                result.counts[CAMERA_INFO_TOPIC] = result.counts.get(CAMERA_INFO_TOPIC, 0) + 1
        writer.write(topic, t, message)
        result.counts[topic] = result.counts.get(topic, 0) + 1
    return topics
