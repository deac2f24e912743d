"""``reprocess``: one streaming pass over a drive into every table, plot and report.

1. Pick the topics, resolve the camera, build the stages and open the frame sinks.
2. :func:`~superlane_tools.drive.run_frames` reads the recording once: every frame through the
   stages into the drive's typed record and the sinks; CAN, IMU and GNSS are collected.
3. :func:`~superlane_tools.drive.drive_tables` turns the record and the signals into the drive's
   tables (pure); they are written with the plots and the report.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

from superlane_tools.can import load_dbcs
from superlane_tools.commands.reprocess._threads import single_native_threads
from superlane_tools.commands.reprocess.outputs import (
    add_signal_channels,
    open_sinks,
    run_provenance,
    write_outputs,
)
from superlane_tools.commands.reprocess.result import (
    Phase,
    Progress,
    ReprocessResult,
    RunClock,
    availability_counts,
    self_check_label,
)
from superlane_tools.corridor import TimeSegment, measurable_range_m
from superlane_tools.drive.config import ReprocessConfig
from superlane_tools.drive.finalize import drive_tables, kpi_segments
from superlane_tools.drive.loop import drive_topics, frame_total, run_frames
from superlane_tools.drive.run_facts import camera_facts
from superlane_tools.drive.selfcheck import SelfCheck, drive_self_check
from superlane_tools.drive.stages import FrameStages
from superlane_tools.recording import open_recording
from superlane_tools.recording.calibration import resolve_camera
from superlane_tools.records import Skipped
from superlane_tools.reporting.drive_notes import timing_line, unlike_training_data
from superlane_tools.reporting.drive_sections import ReportFacts


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
        PipelineError: If it has no camera, CAN or GNSS stream.
        UsageError: For a bad configuration, missing calibration or unusable model.
    """
    cfg = config or ReprocessConfig()
    src, out = Path(recording_path), Path(out_dir)
    clock = RunClock()
    say = phase or (lambda _label: None)
    dbcs, dbc_paths = load_dbcs(cfg.can.dbcs)
    say(f"opening {src.name}")
    with open_recording(src) as rec:
        topics = drive_topics(rec, cfg.topics)
        if not topics.frames:  # truth, dynamics and Mobileye still need no camera
            from superlane_tools.commands.reprocess._signals_only import reprocess_signals

            return reprocess_signals(rec, src, out, cfg, (dbcs, dbc_paths), topics, command)
        camera, camera_source = resolve_camera(rec, topics.streams, cfg.camera)
        total = frame_total(rec, topics.frames)
        say(self_check_label(cfg, total))
        check = drive_self_check(rec, topics.frames, cfg, camera)
        stages = FrameStages(check.config(cfg) if isinstance(check, SelfCheck) else cfg, camera)
        resolved = (topics, camera, stages)
        provenance = run_provenance(src, dbc_paths, cfg, resolved, segments, command, check)
        out.mkdir(parents=True, exist_ok=True)
        sinks = open_sinks(out, cfg, stages, topics.frames, provenance, total)
        say("pass")
        drive = run_frames(rec, topics, stages, sinks.all(), cfg.workers, progress)
        skipped = list(rec.skipped)
    clock.lap()
    say("report: tables, plots, report")
    if drive.failed:
        skipped.append(Skipped("corrupt image", "; ".join(drive.failed[:5]), len(drive.failed)))
    frames, fps = drive.frames, drive.frames.frame_rate_hz()
    kpi = kpi_segments(cfg, frames.t_ns, fps, segments)
    params = cfg.kpi.availability_params(fps)
    signals = (drive.can, dbcs, drive.gnss)
    at_size = stages.camera_for(*stages.process_size(camera.width, camera.height))
    derived = drive_tables(
        frames,
        *signals,
        cfg,
        kpi,
        params,
        stages.corridor_unavailable,
        imu=drive.imu,
        length_cap_m=measurable_range_m(at_size),
        camera_facts=camera_facts(cfg.camera, camera_source, src),
    )
    checked = check.lines() if isinstance(check, SelfCheck) else [check]
    implausible = "" if not isinstance(check, SelfCheck) or check.plausible else check.reason
    notes = (*topics.streams.notes, f"camera: {camera_source}", *checked, *stages.notes)
    notes += (*derived.notes, *([unlike_training_data(implausible)] if implausible else []))
    skipped += derived.lost
    facts = ReportFacts(
        src,
        len(frames),
        stages.backend_name,
        stages.corridor_unavailable,
        notes,
        tuple(skipped),
        implausible,
        timing=timing_line(frames.stage_totals() | clock.pass_timings()),
    )
    written, rendered = sinks.written(drive)
    written += write_outputs(out, derived, provenance, cfg, [], facts, rendered)
    clock.lap()
    timings = frames.stage_totals() | clock.timings()
    return ReprocessResult(
        status="partial" if skipped else "ok",
        skipped=tuple(skipped),
        outputs=tuple(written),
        timings=timings,
        frames=len(frames),
        notes=notes,
        frames_per_s=len(frames) / timings["total"] if timings["total"] > 0 else 0.0,
        signal_channels=add_signal_channels(out, derived) if with_signals else None,
        implausible=unlike_training_data(implausible) if implausible else "",
        availability=availability_counts(derived.availability_sequences, derived.facts),
    )
