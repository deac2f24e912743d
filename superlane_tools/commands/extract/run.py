"""``slt extract``: stream a recording into frames, CAN tables and a GNSS/RTK table."""

from __future__ import annotations

import os
from collections.abc import Callable, Collection, Mapping, Sequence
from dataclasses import asdict
from pathlib import Path

from superlane_tools.can import LoadedDbc, load_dbcs
from superlane_tools.commands.errors import PipelineError
from superlane_tools.commands.extract.config import ExtractConfig, ExtractResult
from superlane_tools.commands.extract.sinks import ExtractSinks, extract_sinks
from superlane_tools.recording import (
    Recording,
    SkipLog,
    message_total,
    open_recording,
    read_with_video,
    select_streams,
    time_range_ns,
)
from superlane_tools.records import Progress, Skipped
from superlane_tools.reporting.atomic import remove_stale_temps
from superlane_tools.reporting.message_pass import stream_messages
from superlane_tools.reporting.provenance import HashedProvenance, PendingIdentities


def extract(
    recording_path: str | os.PathLike[str],
    out_dir: str | os.PathLike[str],
    config: ExtractConfig,
    command: str = "",
    progress: Progress | None = None,
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
        selected = _selected(rec, src, config)
        kind_of = {t: kind for kind, ts in selected.items() for t in ts}
        window = _window(rec, kind_of, config)
        provenance = _provenance(src, dbc_files, config, selected, command)
        whole = window == (None, None)
        total = message_total(rec.topics(), set(kind_of)) if whole else None
        opened = extract_sinks(out, config, selected, dbcs, provenance, skips)
        outputs = _stream(rec, kind_of, window, opened, provenance, total, progress)
        read_skips = list(rec.skipped)
    coverage = opened.can.coverage() if opened.can is not None and dbcs else None
    if coverage is not None and coverage.none_matched:
        detail = f"no CAN id matched by any DBC: 0 of {coverage.seen} ids (wrong DBC?)"
        read_skips.append(Skipped("CAN signals", detail, coverage.seen))
    return ExtractResult(
        outputs=outputs,
        selected=selected,
        counts=opened.counts(),
        dbc_repairs={name: list(d.repairs) for name, d in dbcs.items()},
        skipped=(*read_skips, *skips.items()),
        origin=opened.gnss.used_origin if opened.gnss else None,
        can_coverage=coverage,
    )


def _selected(rec: Recording, src: Path, config: ExtractConfig) -> dict[str, tuple[str, ...]]:
    """Return kind -> topics to extract.

    Raises:
        PipelineError: If no image, CAN or GNSS topic is selected.
    """
    selected = select_streams(rec.topics(), config.topics, config.streams)
    if not any(selected[k] for k in ("frames", "can", "gnss")):
        listing = ", ".join(f"{t.topic} ({t.msgtype})" for t in rec.topics()) or "no topics"
        raise PipelineError(f"{src.name}: no image, CAN or GNSS topics to extract ({listing})")
    return selected


def _window(
    rec: Recording, topics: Collection[str], config: ExtractConfig
) -> tuple[int | None, int | None]:
    """Return the ``[start, stop)`` log times to extract, ns (None: the recording's own end)."""
    start_ns, stop_ns = time_range_ns(rec, list(topics), config.start_s, config.end_s)
    start_ns = config.start_ns if config.start_ns is not None else start_ns
    stop_ns = config.end_ns if config.end_ns is not None else stop_ns
    return start_ns, stop_ns


def _provenance(
    src: Path,
    dbc_files: Sequence[Path],
    config: ExtractConfig,
    selected: Mapping[str, tuple[str, ...]],
    command: str,
) -> HashedProvenance:
    """Return the tables' provenance: the inputs (hashed while streaming), command, settings."""
    settings = asdict(config)
    settings["streams"] = {k: list(v) for k, v in selected.items()}
    return HashedProvenance(
        PendingIdentities((src, *dbc_files)),
        command=command,
        config=settings,
    )


def _stream(
    rec: Recording,
    kind_of: Mapping[str, str],
    window: tuple[int | None, int | None],
    opened: ExtractSinks,
    provenance: HashedProvenance,
    total: int | None,
    progress: Progress | None,
) -> tuple[Path, ...]:
    """Stream the selected topics of the window into their kinds' sinks; return the files."""
    by_kind = opened.by_kind()
    sinks = [s for s in by_kind.values() if s is not None]
    route = {t: sink for t, kind in kind_of.items() if (sink := by_kind[kind]) is not None}
    messages = read_with_video(rec, list(kind_of), *window)

    def tick(done: int) -> None:
        if progress is not None:
            progress(done, total)

    try:
        read = stream_messages(messages, route, sinks, tick)
    except BaseException:
        provenance.cancel()
        raise
    if progress is not None:
        progress(read.messages, read.messages)
    return tuple(path for files in read.files for path in files)
