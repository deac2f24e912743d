"""``slt extract``: stream a recording into frames, CAN tables and a GNSS/RTK table."""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import asdict
from pathlib import Path
from typing import Any

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
from superlane_tools.reporting.can_sink import CanSink
from superlane_tools.reporting.frame_sink import FrameSink
from superlane_tools.reporting.gnss_sink import GnssSink
from superlane_tools.reporting.layout import CAMERA_INFO_TABLE, EXTRACT_FRAMES_TABLE, ExtractLayout
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
        layout = ExtractLayout(out)
        frame_sink = (
            FrameSink(
                out,
                config.frame_format,
                config.every,
                provenance,
                skips,
                index_name=EXTRACT_FRAMES_TABLE.file,
                images_name="frames",
                camera_info_name=CAMERA_INFO_TABLE.file,
            )
            if selected["frames"] or selected["camera_info"]
            else None
        )
        can_sink = (
            CanSink(layout.can_raw, layout.can_signals, dbcs, provenance)
            if selected["can"]
            else None
        )
        gnss_sink = GnssSink(layout.rtk, config.origin, provenance) if selected["gnss"] else None
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
