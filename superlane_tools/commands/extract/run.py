"""``slt extract``: stream a recording into frames, CAN tables and a GNSS/RTK table."""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping
from dataclasses import asdict
from pathlib import Path
from typing import NamedTuple

from superlane_tools.can import LoadedDbc, load_dbcs
from superlane_tools.commands.errors import PipelineError
from superlane_tools.commands.extract.config import ExtractConfig, ExtractResult
from superlane_tools.recording import (
    SkipLog,
    message_total,
    open_recording,
    read_with_video,
    select_streams,
    time_range_ns,
)
from superlane_tools.records import Skipped
from superlane_tools.reporting.atomic import remove_stale_temps
from superlane_tools.reporting.camera_info_sink import CameraInfoSink
from superlane_tools.reporting.can_sink import CanSink
from superlane_tools.reporting.gnss_sink import RtkSink
from superlane_tools.reporting.image_file_sink import ImageFileSink
from superlane_tools.reporting.layout import EXTRACT_FRAMES_TABLE, ExtractLayout
from superlane_tools.reporting.message_pass import MessageSink, stream_messages
from superlane_tools.reporting.provenance import HashedProvenance, PendingIdentities


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
        on_dbc: Called for each loaded DBC, with its name and repairs (for reporting).

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
    dbcs, dbc_files = load_dbcs([str(p) for p in config.dbc_paths], shipped=False)
    for name, loaded in dbcs.items():
        if on_dbc is not None:
            on_dbc(name, loaded)
    skips = SkipLog()
    with open_recording(src) as rec:
        selected = select_streams(rec.topics(), config.topics, config.streams)
        kind_of = {t: kind for kind, ts in selected.items() for t in ts}
        if not any(selected[k] for k in ("frames", "can", "gnss")):
            listing = ", ".join(f"{t.topic} ({t.msgtype})" for t in rec.topics()) or "no topics"
            raise PipelineError(f"{src.name}: no image, CAN or GNSS topics to extract ({listing})")
        start_ns, stop_ns = time_range_ns(rec, list(kind_of), config.start_s, config.end_s)
        start_ns = config.start_ns if config.start_ns is not None else start_ns
        stop_ns = config.end_ns if config.end_ns is not None else stop_ns
        settings = asdict(config)
        settings["streams"] = {k: list(v) for k, v in selected.items()}
        provenance = HashedProvenance(
            PendingIdentities((src, *dbc_files)),
            command=command,
            config=settings,
        )
        whole = start_ns is None and stop_ns is None
        total = message_total(rec.topics(), set(kind_of)) if whole else None
        opened = _sinks(out, config, selected, dbcs, provenance, skips)
        by_kind = opened.by_kind()
        sinks = [s for s in by_kind.values() if s is not None]
        route = {t: sink for t, kind in kind_of.items() if (sink := by_kind[kind]) is not None}
        messages = read_with_video(rec, list(kind_of), start_ns, stop_ns)

        def tick(done: int) -> None:
            if progress is not None:
                progress(done, total)

        try:
            read = stream_messages(messages, route, sinks, tick)
        except BaseException:
            provenance.cancel()
            raise
        outputs = [path for files in read.files for path in files]
        if progress is not None:
            progress(read.messages, read.messages)
        read_skips = list(rec.skipped)
    image_sink, can_sink, gnss_sink = opened.frames, opened.can, opened.gnss
    coverage = can_sink.coverage() if can_sink is not None and dbcs else None
    if coverage is not None and coverage.none_matched:
        detail = f"no CAN id matched by any DBC: 0 of {coverage.seen} ids (wrong DBC?)"
        read_skips.append(Skipped("CAN signals", detail, coverage.seen))
    counts = {
        "frames": image_sink.kept if image_sink else 0,
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


class _Sinks(NamedTuple):
    """The sink of each stream kind (None: the kind is not extracted)."""

    frames: ImageFileSink | None
    camera_info: CameraInfoSink | None
    can: CanSink | None
    gnss: RtkSink | None

    def by_kind(self) -> dict[str, MessageSink | None]:
        """Return stream kind -> its sink, in the order the sinks are closed."""
        kinds = ("frames", "camera_info", "can", "gnss")
        sinks: tuple[MessageSink | None, ...] = (self.frames, self.camera_info, self.can, self.gnss)
        return dict(zip(kinds, sinks, strict=True))


def _sinks(
    out: Path,
    config: ExtractConfig,
    selected: Mapping[str, tuple[str, ...]],
    dbcs: dict[str, LoadedDbc],
    provenance: HashedProvenance,
    skips: SkipLog,
) -> _Sinks:
    """Open the sink of each selected stream kind, writing under ``out``."""
    layout = ExtractLayout(out)
    frames = selected["frames"] or selected["camera_info"]  # frames.parquet, empty or not
    return _Sinks(
        frames=ImageFileSink(
            out,
            config.frame_format,
            config.every,
            provenance,
            skips,
            index_name=EXTRACT_FRAMES_TABLE.file,
            images_name="frames",
        )
        if frames
        else None,
        camera_info=CameraInfoSink(layout.camera_info, provenance)
        if selected["camera_info"]
        else None,
        can=CanSink(layout.can_raw, layout.can_signals, dbcs, provenance)
        if selected["can"]
        else None,
        gnss=RtkSink(layout.rtk, config.origin, provenance) if selected["gnss"] else None,
    )
