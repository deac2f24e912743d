"""``slt extract``: stream a recording into frames, CAN tables and a GNSS/RTK table."""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from superlane_tools.can import ALL_BUSES, Coverage, LoadedDbc, load_dbc, parse_dbc_spec
from superlane_tools.commands.errors import PipelineError
from superlane_tools.errors import ConfigError, UsageError
from superlane_tools.geo import GeodeticOrigin
from superlane_tools.recording.base import Recording, SkipLog
from superlane_tools.recording.open import open_recording
from superlane_tools.recording.streams import STREAM_KINDS, load_stream_config, select_streams
from superlane_tools.recording.video import read_with_video
from superlane_tools.records import Skipped, TopicInfo
from superlane_tools.reporting.atomic import remove_stale_temps
from superlane_tools.reporting.can_sink import CanSink
from superlane_tools.reporting.frame_sink import FrameSink
from superlane_tools.reporting.gnss_sink import GnssSink
from superlane_tools.reporting.provenance import HashedProvenance, PendingIdentities

MAX_OFFSET_S = 9e9
"""Largest --start/--end offset, seconds (int64 ns holds 292 years)."""
FRAME_FORMATS = ("jpg", "png", "none")
_NS = 1_000_000_000
__all__ = [
    "FRAME_FORMATS",
    "STREAM_KINDS",
    "ExtractConfig",
    "ExtractResult",
    "extract",
    "load_stream_config",
    "select_streams",
]


@dataclass(frozen=True)
class ExtractConfig:
    """What to extract and how.

    Attributes:
        topics: Restrict to these topics (streams still found by message type); empty: all.
        streams: Explicit topic lists per kind (``frames``, ``camera_info``, ``can``, ``gnss``),
            e.g. from a YAML config; a kind listed here is not auto-detected.
        start_s: Start of the range, seconds after the recording's first message; None: start.
        end_s: End of the range (exclusive), seconds after the first message; None: end.
        start_ns: Start as an absolute log time, ns (overrides ``start_s``).
        end_ns: End (exclusive) as an absolute log time, ns (overrides ``end_s``).
        dbc_paths: DBC files to decode CAN frames with (none: raw frames only); ``BUS=FILE``
            binds a DBC to one bus (CAN topic or channel), a plain file applies to all.
        frame_format: ``jpg``, ``png`` (files) or ``none`` (index only).
        every: Keep every Nth frame of each image topic.
        origin: ENU origin; None: the first valid fix.
    """

    topics: tuple[str, ...] = ()
    streams: Mapping[str, tuple[str, ...]] = field(default_factory=dict)
    start_s: float | None = None
    end_s: float | None = None
    start_ns: int | None = None
    end_ns: int | None = None
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
        can_coverage: Ids matched by the DBCs of the ids seen (None without CAN or DBCs).
    """

    outputs: tuple[Path, ...]
    selected: Mapping[str, tuple[str, ...]]
    counts: Mapping[str, int]
    dbc_repairs: Mapping[str, list[str]]
    skipped: tuple[Skipped, ...]
    origin: GeodeticOrigin | None
    can_coverage: Coverage | None = None


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
    specs = [parse_dbc_spec(str(p)) for p in config.dbc_paths]
    for spec in specs:
        loaded = load_dbc(spec.path)
        name = spec.path.name if spec.bus == ALL_BUSES else f"{spec.bus}={spec.path.name}"
        dbcs[name] = loaded
        if on_dbc is not None:
            on_dbc(name, loaded)
    skips = SkipLog()
    with open_recording(src) as rec:
        selected = select_streams(rec.topics(), config.topics, config.streams)
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
        start_ns = config.start_ns if config.start_ns is not None else start_ns
        stop_ns = config.end_ns if config.end_ns is not None else stop_ns
        settings = asdict(config)
        settings["streams"] = {k: list(v) for k, v in selected.items()}
        provenance = HashedProvenance(
            PendingIdentities((src, *(spec.path for spec in specs))),
            command=command,
            config=settings,
        )
        total = _total(rec.topics(), set(kind_of)) if start_ns is None and stop_ns is None else None
        frame_sink = (
            FrameSink(
                out,
                config.frame_format,
                config.every,
                provenance,
                skips,
                index_name="frames.parquet",
                images_name="frames",
                camera_info_name="camera_info.parquet",
            )
            if selected["frames"] or selected["camera_info"]
            else None
        )
        can_sink = (
            CanSink(out / "can_raw.parquet", out / "can_signals.parquet", dbcs, provenance)
            if selected["can"]
            else None
        )
        gnss_sink = (
            GnssSink(out / "rtk.parquet", config.origin, provenance) if selected["gnss"] else None
        )
        sinks: list[Any] = [s for s in (frame_sink, can_sink, gnss_sink) if s is not None]
        done = 0
        ok = False
        try:
            for msg in read_with_video(rec, list(kind_of), start_ns, stop_ns):
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
    coverage = can_sink.coverage() if can_sink is not None and dbcs else None
    if coverage is not None and coverage.none_matched:
        detail = f"no CAN id matched by any DBC: 0 of {coverage.seen} ids (wrong DBC?)"
        read_skips.append(Skipped("CAN signals", detail, coverage.seen))
    counts = {
        "frames": frame_sink.kept if frame_sink else 0,
        "can_frames": can_sink.frames if can_sink else 0,
        "can_signals": can_sink.signal_rows if can_sink else 0,
        "gnss_fixes": len(gnss_sink) if gnss_sink else 0,
    }
    return ExtractResult(
        outputs=tuple(outputs),
        selected=selected,
        counts=counts,
        dbc_repairs={name: list(d.repairs) for name, d in dbcs.items()},
        skipped=(*read_skips, *skips.items()),
        origin=gnss_sink.used_origin if gnss_sink else None,
        can_coverage=coverage,
    )


def _total(topics: Sequence[TopicInfo], selected: set[str]) -> int | None:
    counts = [t.message_count for t in topics if t.topic in selected]
    if any(c is None for c in counts):
        return None
    return sum(c for c in counts if c is not None)
