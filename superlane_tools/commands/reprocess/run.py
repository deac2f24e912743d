"""``reprocess``: one drive into every table, plot and report.

1. :func:`~superlane_tools.drive.reprocess_pass.reprocess_pass` resolves the drive (topics,
   camera, self-check, stages), asks :class:`~superlane_tools.commands.reprocess.outputs.
   RunOutputs` for the frame sinks, reads the recording once and builds the drive's tables.
2. ``RunOutputs`` writes the tables, plots and report; the result says what was done and lost.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

from superlane_tools.can import load_dbcs
from superlane_tools.commands.reprocess._threads import single_native_threads
from superlane_tools.commands.reprocess.outputs import RunOutputs, add_signal_channels
from superlane_tools.commands.reprocess.result import ReprocessResult
from superlane_tools.corridor import TimeSegment
from superlane_tools.drive.config import ReprocessConfig
from superlane_tools.drive.reprocess_pass import Phase, reprocess_pass
from superlane_tools.recording import open_recording
from superlane_tools.records import Progress
from superlane_tools.reporting.drive_notes import unlike_training_data


@single_native_threads()  # BLAS and OpenCV pools at one thread: our workers fill the cores
def reprocess(
    recording_path: str | os.PathLike[str],
    out_dir: str | os.PathLike[str],
    config: ReprocessConfig | None = None,
    progress: Progress | None = None,
    command: str = "",
    segments: Sequence[TimeSegment] | None = None,
    with_signals: bool = False,
    phase: Phase | None = None,
) -> ReprocessResult:
    """Reprocess one drive into tables, plots, a report and Foxglove annotations.

    Args:
        recording_path: A recording :func:`~superlane_tools.recording.open_recording` opens.
        out_dir: Output folder (created).
        config: Configuration (defaults when None).
        progress: Called as ``progress(frames_done, frames_total_or_None)``.
        command: Command line for the provenance.
        segments: KPI sequences of the drive (None: ``kpi.manifest``, else windows).
        with_signals: Also add the decoded CAN signals and truth curves to the annotations.
        phase: Called with a label as each phase starts (opening, self-check, pass, report).

    Returns:
        Status, outputs, skipped data, timings and notes.

    Raises:
        RecordingError: If the input is not a recording.
        DriveError: If it has no camera, CAN or GNSS stream.
        UsageError: For a bad configuration, missing calibration or unusable model.
    """
    cfg = config or ReprocessConfig()
    src, out = Path(recording_path), Path(out_dir)
    dbcs, dbc_paths = load_dbcs(cfg.can.dbcs)
    outputs = RunOutputs(out, cfg, (src, dbc_paths), segments, command)
    if phase is not None:
        phase(f"opening {src.name}")
    with open_recording(src) as rec:
        drive = reprocess_pass(rec, src, cfg, outputs.open, dbcs, segments, progress, phase)
    written = outputs.write(drive)
    drive.clock.lap()
    timings, reason = drive.timings(), drive.facts.implausible
    return ReprocessResult(
        status="partial" if drive.skipped else "ok",
        skipped=drive.skipped,
        outputs=tuple(written),
        timings=timings,
        frames=drive.camera_frames,
        notes=drive.facts.notes,
        frames_per_s=drive.camera_frames / timings["total"] if timings["total"] > 0 else 0.0,
        signal_channels=add_signal_channels(out, drive.derived) if with_signals else None,
        implausible=unlike_training_data(reason) if reason else "",
        availability=drive.availability(),
    )
