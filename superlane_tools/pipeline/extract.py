"""``slt extract``: stream a recording into frames, CAN tables and a GNSS/RTK table."""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from superlane_tools.can import LoadedDbc, load_dbc
from superlane_tools.errors import ConfigError, UsageError
from superlane_tools.geo import GeodeticOrigin
from superlane_tools.pipeline._can_sink import CanSink
from superlane_tools.pipeline._frame_sink import FrameSink
from superlane_tools.pipeline._gnss_sink import GnssSink
from superlane_tools.pipeline.errors import PipelineError
from superlane_tools.recording.base import Recording, SkipLog
from superlane_tools.recording.open import open_recording
from superlane_tools.records import Skipped, TopicInfo
from superlane_tools.reporting import Provenance
from superlane_tools.reporting.atomic import remove_stale_temps
from superlane_tools.reporting.provenance import PendingIdentities

FRAME_TYPES = frozenset(
    {
        "sensor_msgs/msg/Image",
        "sensor_msgs/msg/CompressedImage",
        "foxglove.CompressedImage",
        "foxglove.RawImage",
    }
)
CAMERA_INFO_TYPES = frozenset({"sensor_msgs/msg/CameraInfo", "foxglove.CameraCalibration"})
CAN_TYPES = frozenset({"can_msgs/msg/Frame"})
GNSS_TYPES = frozenset({"sensor_msgs/msg/NavSatFix", "foxglove.LocationFix"})
MAX_OFFSET_S = 9e9
"""Largest --start/--end offset, seconds (int64 ns holds 292 years)."""
STREAM_KINDS = ("frames", "camera_info", "can", "gnss")
FRAME_FORMATS = ("jpg", "png", "none")
_KIND_TYPES = {
    "frames": FRAME_TYPES,
    "camera_info": CAMERA_INFO_TYPES,
    "can": CAN_TYPES,
    "gnss": GNSS_TYPES,
}
_NS = 1_000_000_000


@dataclass(frozen=True)
class ExtractConfig:
    """What to extract and how.

    Attributes:
        topics: Restrict to these topics (streams still found by message type); empty: all.
        streams: Explicit topic lists per kind (``frames``, ``camera_info``, ``can``, ``gnss``),
            e.g. from a YAML config; a kind listed here is not auto-detected.
        start_s: Start of the range, seconds after the recording's first message; None: start.
        end_s: End of the range (exclusive), seconds after the first message; None: end.
        dbc_paths: DBC files to decode CAN frames with (none: raw frames only).
        frame_format: ``jpg``, ``png`` (files) or ``none`` (index only).
        every: Keep every Nth frame of each image topic.
        origin: ENU origin; None: the first valid fix.
    """

    topics: tuple[str, ...] = ()
    streams: Mapping[str, tuple[str, ...]] = field(default_factory=dict)
    start_s: float | None = None
    end_s: float | None = None
    dbc_paths: tuple[Path, ...] = ()
    frame_format: str = "jpg"
    every: int = 1
    origin: GeodeticOrigin | None = None

    def __post_init__(self) -> None:
        if self.frame_format not in FRAME_FORMATS:
            raise UsageError(
                f"frame format must be one of {FRAME_FORMATS}, not {self.frame_format!r}"
            )
        if self.every < 1:
            raise UsageError(f"--every must be >= 1, got {self.every}")
        for name, value in (("--start", self.start_s), ("--end", self.end_s)):
            if value is not None and not (math.isfinite(value) and abs(value) <= MAX_OFFSET_S):
                raise UsageError(f"{name} must be a finite number of seconds, got {value}")
        if self.start_s is not None and self.start_s < 0:
            raise UsageError(f"--start must be >= 0 s, got {self.start_s}")
        if self.end_s is not None and self.end_s <= (self.start_s or 0.0):
            start = self.start_s or 0.0
            raise UsageError(f"--end ({self.end_s} s) must be after --start ({start} s)")
        unknown = set(self.streams) - set(STREAM_KINDS)
        if unknown:
            raise ConfigError(f"unknown stream kinds {sorted(unknown)}: use {STREAM_KINDS}")


@dataclass(frozen=True)
class ExtractResult:
    """What an extraction produced.

    Attributes:
        outputs: Files written (Parquet tables; image files are listed in ``frames.parquet``).
        selected: Kind -> topics extracted.
        counts: Kind -> rows written (frames indexed, CAN frames, signal rows, fixes).
        dbc_repairs: DBC file name -> repairs made while loading it.
        skipped: What was skipped or lost (reading errors, corrupt frames), one entry per kind.
        origin: The ENU origin used, when GNSS was extracted.
    """

    outputs: tuple[Path, ...]
    selected: Mapping[str, tuple[str, ...]]
    counts: Mapping[str, int]
    dbc_repairs: Mapping[str, list[str]]
    skipped: tuple[Skipped, ...]
    origin: GeodeticOrigin | None


def load_stream_config(path: str | os.PathLike[str]) -> dict[str, tuple[str, ...]]:
    """Read a YAML config ``{frames: [...], camera_info: [...], can: [...], gnss: [...]}``.

    Raises:
        ConfigError: If the file is unreadable, not a mapping, or has unknown keys or non-list
            values.
    """
    import yaml

    src = Path(path)
    try:
        raw = yaml.safe_load(src.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, yaml.YAMLError) as err:
        raise ConfigError(f"{src}: cannot read extract config: {err}") from err
    if raw is None:
        return {}
    if not isinstance(raw, dict):
        raise ConfigError(f"{src}: extract config must be a mapping of {STREAM_KINDS} to topics")
    streams: dict[str, tuple[str, ...]] = {}
    for key, value in raw.items():
        if key not in STREAM_KINDS:
            raise ConfigError(f"{src}: unknown key {key!r}; expected {STREAM_KINDS}")
        items = [value] if isinstance(value, str) else value
        if not isinstance(items, list) or not all(isinstance(t, str) for t in items):
            raise ConfigError(f"{src}: {key} must be a list of topic names")
        streams[key] = tuple(items)
    return streams


def select_streams(
    topics: Sequence[TopicInfo], config: ExtractConfig
) -> dict[str, tuple[str, ...]]:
    """Assign topics to kinds by message type, honouring ``config.topics`` and ``streams``.

    Raises:
        UsageError: If a requested topic is not in the recording.
    """
    available = {t.topic: t.msgtype for t in topics}
    wanted = [*config.topics, *(t for ts in config.streams.values() for t in ts)]
    missing = sorted({t for t in wanted if t not in available})
    if missing:
        listing = ", ".join(sorted(available)) or "none"
        raise UsageError(f"topics not in the recording: {', '.join(missing)} (it has: {listing})")
    allowed = set(config.topics) if config.topics else set(available)
    selected: dict[str, tuple[str, ...]] = {}
    claimed = {t for ts in config.streams.values() for t in ts}
    for kind in STREAM_KINDS:
        if kind in config.streams:
            selected[kind] = tuple(config.streams[kind])
            continue
        types = _KIND_TYPES[kind]
        selected[kind] = tuple(
            sorted(
                t for t, m in available.items() if m in types and t in allowed and t not in claimed
            )
        )
    return selected


def _first_log_time_ns(rec: Recording, topics: Sequence[str]) -> int | None:
    for raw in rec.raw_messages(topics=topics):
        return raw.log_time_ns
    return None


def extract(
    recording_path: str | os.PathLike[str],
    out_dir: str | os.PathLike[str],
    config: ExtractConfig,
    command: str = "",
    progress: Callable[[int, int | None], None] | None = None,
    on_dbc: Callable[[str, LoadedDbc], None] | None = None,
) -> ExtractResult:
    """Extract frames, camera info, CAN and GNSS from a recording in one streaming pass.

    Outputs under ``out_dir``: ``frames/<topic>/<index:06d>.<ext>`` and ``frames.parquet``,
    ``camera_info.parquet``, ``can_raw.parquet`` (and ``can_signals.parquet`` with DBCs),
    ``rtk.parquet``; each Parquet file atomic, in row groups, with provenance metadata. Only
    the kinds the recording has are written.

    Args:
        recording_path: Any recording :func:`~superlane_tools.recording.open.open_recording`
            opens (MCAP, ROS 1/2 bag, CAN log, NMEA log).
        out_dir: Output folder (created).
        config: What to extract.
        command: Command line for the provenance.
        progress: Called as ``progress(messages_done, messages_total_or_None)`` every few
            hundred messages.
        on_dbc: Called after each DBC loads, with its name and repairs (for reporting).

    Returns:
        The outputs, counts, DBC repairs and what was skipped.

    Raises:
        RecordingError: If the input is not a recording.
        CanError: If a DBC cannot be loaded.
        PipelineError: If the recording has none of the selected streams.
        UsageError: If requested topics are missing.
    """
    src = Path(recording_path)
    out = Path(out_dir)
    for folder in (out, out / "frames"):  # what killed extracts into this folder left
        remove_stale_temps(folder)
    dbcs: dict[str, LoadedDbc] = {}
    for dbc_path in config.dbc_paths:
        loaded = load_dbc(dbc_path)
        dbcs[Path(dbc_path).name] = loaded
        if on_dbc is not None:
            on_dbc(Path(dbc_path).name, loaded)
    skips = SkipLog()
    with open_recording(src) as rec:
        selected = select_streams(rec.topics(), config)
        kind_of = {t: kind for kind, ts in selected.items() for t in ts}
        if not any(selected[k] for k in ("frames", "can", "gnss")):
            listing = ", ".join(f"{t.topic} ({t.msgtype})" for t in rec.topics()) or "no topics"
            raise PipelineError(f"{src.name}: no image, CAN or GNSS topics to extract ({listing})")
        start_ns = stop_ns = None
        if config.start_s is not None or config.end_s is not None:
            first = _first_log_time_ns(rec, list(kind_of))
            if first is not None:
                start_ns = None if config.start_s is None else first + round(config.start_s * _NS)
                stop_ns = None if config.end_s is None else first + round(config.end_s * _NS)
        settings = asdict(config)
        settings["streams"] = {k: list(v) for k, v in selected.items()}
        provenance = _HashedProvenance(
            PendingIdentities((src, *config.dbc_paths)), command=command, config=settings
        )
        total = _total(rec.topics(), set(kind_of)) if start_ns is None and stop_ns is None else None
        frame_sink = (
            FrameSink(out, config.frame_format, config.every, provenance, skips)
            if selected["frames"] or selected["camera_info"]
            else None
        )
        can_sink = CanSink(out, dbcs, provenance) if selected["can"] else None
        gnss_sink = GnssSink(out, config.origin, provenance) if selected["gnss"] else None
        sinks: list[Any] = [s for s in (frame_sink, can_sink, gnss_sink) if s is not None]
        done = 0
        ok = False
        try:
            for msg in rec.messages(topics=list(kind_of), start_ns=start_ns, stop_ns=stop_ns):
                kind = kind_of[msg.topic]
                if kind == "can" and can_sink is not None:
                    can_sink.add(msg)
                elif kind == "frames" and frame_sink is not None:
                    frame_sink.add(msg)
                elif kind == "gnss" and gnss_sink is not None:
                    gnss_sink.add(msg)
                elif kind == "camera_info" and frame_sink is not None:
                    frame_sink.add_camera_info(msg)
                done += 1
                if progress is not None and done % 256 == 0:
                    progress(done, total)
            ok = True
        finally:
            if not ok:
                provenance.cancel()
            outputs: list[Path] = []
            for sink in sinks:
                outputs.extend(sink.close(ok))
        if progress is not None:
            progress(done, done)
        read_skips = list(rec.skipped)
    counts = {
        "frames": frame_sink.kept if frame_sink else 0,
        "can_frames": can_sink.frames if can_sink else 0,
        "can_signals": can_sink.signal_rows if can_sink else 0,
        "gnss_fixes": len(gnss_sink.rows) if gnss_sink else 0,
    }
    return ExtractResult(
        outputs=tuple(outputs),
        selected=selected,
        counts=counts,
        dbc_repairs={name: list(d.repairs) for name, d in dbcs.items()},
        skipped=(*read_skips, *skips.items()),
        origin=gnss_sink.used_origin if gnss_sink else None,
    )


class _HashedProvenance:
    """The extraction's provenance, finished once the inputs' background hashing is done.

    The recording is hashed (SHA-256) in a background thread while it is extracted; the
    Parquet writers call this object when they first need the provenance.
    """

    def __init__(self, pending: PendingIdentities, command: str, config: dict[str, Any]) -> None:
        self._pending = pending
        self._command = command
        self._config = config
        self._provenance: Provenance | None = None

    def __call__(self) -> Provenance:
        """Return the provenance, waiting for the hashes if needed.

        Raises:
            PipelineError: If an input could not be read for hashing.
        """
        if self._provenance is None:
            try:
                inputs = self._pending.result()
            except OSError as err:
                raise PipelineError(f"cannot hash input {err.filename}: {err.strerror}") from err
            self._provenance = Provenance(command=self._command, inputs=inputs, config=self._config)
        return self._provenance

    def cancel(self) -> None:
        """Stop hashing (the extraction failed)."""
        self._pending.cancel()


def _total(topics: Sequence[TopicInfo], selected: set[str]) -> int | None:
    counts = [t.message_count for t in topics if t.topic in selected]
    if any(c is None for c in counts):
        return None
    return sum(c for c in counts if c is not None)
