"""One drive reprocessed: what it resolves to, one pass over it, its tables and report facts.

:func:`reprocess_pass` is the drive layer's one verb for ``slt reprocess``:

1. pick the topics; without a camera, a grid of evaluation times stands in for the frames
   (truth, the dynamics reference and Mobileye still need no image);
2. resolve the camera, run the segmentation self-check and build the stages (a
   :class:`PassSetup`), then ask the caller for the frame sinks of that setup;
3. read the recording once (:func:`~superlane_tools.drive.loop.run_frames`), then turn the
   record and the signals into the drive's tables (:func:`~superlane_tools.drive.finalize.
   drive_tables`, pure) and the report's facts.

The caller (the command) owns the files: it opens the sinks and writes the tables, plots and
report from the returned :class:`DriveOutcome`.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from superlane_tools.corridor import Segment, TimeSegment, measurable_range_m, windows
from superlane_tools.drive.config import ReprocessConfig
from superlane_tools.drive.errors import DriveError
from superlane_tools.drive.finalize import DerivedTables, drive_tables, kpi_segments
from superlane_tools.drive.loop import (
    DriveTopics,
    FrameSink,
    drive_topics,
    frame_total,
    run_frames,
)
from superlane_tools.drive.record import DriveFrames, no_camera_frames
from superlane_tools.drive.run_facts import camera_facts
from superlane_tools.drive.selfcheck import CLIP_FRAMES, SAMPLE_CLIPS, SelfCheck, drive_self_check
from superlane_tools.drive.stages import FrameStages
from superlane_tools.recording.calibration import resolve_camera
from superlane_tools.records import Progress, Skipped
from superlane_tools.reporting.drive_notes import timing_line, unlike_training_data
from superlane_tools.reporting.drive_sections import ReportFacts

if TYPE_CHECKING:
    from superlane_tools.camera.model import CameraModel
    from superlane_tools.can import LoadedDbc

GRID_HZ = 15.0
"""Evaluation rate without camera frames (the corridor paper's camera rate), Hz."""
NO_CAMERA = "no camera stream"

Phase = Callable[[str], None]
"""Called with a label when a phase of the run starts (``self-check on 16 frames``, ``pass``,
``report``), so that the progress display says what the time goes to."""


class RunClock:
    """Wall and process CPU time of a run's two phases: the streaming pass and what follows."""

    def __init__(self) -> None:
        self._wall = [time.perf_counter()]
        self._cpu = [time.process_time()]

    def lap(self) -> None:
        """Mark the end of a phase (the pass, then the tables, plots and report)."""
        self._wall.append(time.perf_counter())
        self._cpu.append(time.process_time())

    def pass_timings(self) -> dict[str, float]:
        """Return ``pass_wall`` and ``cpu_pass`` (call after the first lap)."""
        (w0, w1), (c0, c1) = self._wall[:2], self._cpu[:2]
        return {"pass_wall": w1 - w0, "cpu_pass": c1 - c0}

    def timings(self) -> dict[str, float]:
        """Return ``pass_wall``, ``post``, ``total`` and ``cpu_pass``, ``cpu_post``, ``cpu_total``.

        Call after two laps.
        """
        (w0, w1, w2), (c0, c1, c2) = self._wall[:3], self._cpu[:3]
        return {
            "pass_wall": w1 - w0,
            "post": w2 - w1,
            "total": w2 - w0,
            "cpu_pass": c1 - c0,
            "cpu_post": c2 - c1,
            "cpu_total": c2 - c0,
        }


@dataclass(frozen=True)
class PassSetup:
    """What a drive resolved to before its pass: what the sinks and the provenance record.

    Attributes:
        topics: The topics read.
        camera: The camera model (None without a camera stream).
        stages: The per-frame stages (None without a camera stream).
        check: The segmentation self-check, or why it was skipped ("" without a camera).
        total: Camera frames in the recording when its summary knows them.
    """

    topics: DriveTopics
    camera: CameraModel | None = None
    stages: FrameStages | None = None
    check: SelfCheck | str = ""
    total: int | None = None


SinkOpener = Callable[[PassSetup], Sequence[FrameSink]]
"""Opens the frame sinks of a resolved drive (called once, before the pass)."""


@dataclass(frozen=True)
class DriveOutcome:
    """One reprocessed drive: its tables, what the report states, what was lost.

    Attributes:
        setup: What the drive resolved to.
        derived: The drive's tables (:func:`~superlane_tools.drive.finalize.drive_tables`).
        facts: What the report states besides the tables (header and input size: the writer's).
        files: Per frame sink, in the order opened, the files its ``close`` returned.
        frames: The drive's per-frame record (evaluation instants without a camera).
        clock: The run's clock, lapped after the pass (the writer laps it once more).
    """

    setup: PassSetup
    derived: DerivedTables
    facts: ReportFacts
    files: tuple[tuple[Path, ...], ...]
    frames: DriveFrames
    clock: RunClock

    @property
    def camera(self) -> bool:
        """Whether the drive had a camera stream (the image methods ran)."""
        return self.setup.stages is not None

    @property
    def camera_frames(self) -> int:
        """Camera frames processed (0 without a camera: the grid's instants are no frames)."""
        return len(self.frames) if self.camera else 0

    @property
    def skipped(self) -> tuple[Skipped, ...]:
        """What was lost: reading errors, undecodable frames, data the tables could not use."""
        return self.facts.skipped

    def timings(self) -> dict[str, float]:
        """Return the run's seconds (call after the writer's lap; see ``ReprocessResult``).

        With a camera: per stage, then the pass, the writing and the total; without one, the
        total.
        """
        if not self.camera:
            return {"total": self.clock.timings()["total"]}
        return self.frames.stage_totals() | self.clock.timings()

    def availability(self) -> tuple[tuple[str, int, int, int], ...]:
        """Return ``(method, frames, available, unknown)`` over the drive per method that ran.

        Empty without a camera (the report states Mobileye's; the command's last line has
        no image method to name).
        """
        if not self.camera:
            return ()
        sequences, out = self.derived.availability_sequences, []
        for method in self.derived.facts.methods_run():
            rows = sequences[sequences["method"] == method] if len(sequences) else sequences
            if len(rows):
                n_frames, n_available, n_unknown = (
                    int(rows[c].sum()) for c in ("n_frames", "n_available", "n_unknown")
                )
                out.append((method, n_frames, n_available, n_unknown))
        return tuple(out)


def self_check_label(config: ReprocessConfig, total: int | None) -> str:
    """Return the progress label of the self-check phase (or of stage set-up without one)."""
    seg = config.segmentation
    if seg.backend != "auto" or seg.model:
        return "loading the segmentation model"
    n = SAMPLE_CLIPS * CLIP_FRAMES
    return f"self-check on {min(n, total) if total else n} frames"


def reprocess_pass(
    recording: Any,
    source: Path,
    config: ReprocessConfig,
    sinks: SinkOpener,
    dbcs: dict[str, LoadedDbc],
    segments: Sequence[TimeSegment] | None = None,
    progress: Progress | None = None,
    phase: Phase | None = None,
) -> DriveOutcome:
    """Reprocess one open drive: resolve it, read it once, build its tables and report facts.

    Args:
        recording: An open recording (:func:`~superlane_tools.recording.open_recording`).
        source: Its path (the report and the camera's facts name it).
        config: The configuration.
        sinks: Opens the frame sinks of the resolved drive (not called without a camera).
        dbcs: DBCs by name (``BUS=FILE`` names bind a bus).
        segments: KPI sequences of the drive (None: ``kpi.manifest``, else windows).
        progress: Called as ``progress(frames_done, frames_total_or_None)``.
        phase: Called with a label as each phase starts (self-check, pass, report).

    Raises:
        DriveError: If the recording has no camera, CAN or GNSS stream.
        UsageError: For a bad configuration, missing calibration or unusable model.
    """
    clock = RunClock()
    say = phase or (lambda _label: None)
    topics = drive_topics(recording, config.topics)
    if not topics.frames:  # truth, dynamics and Mobileye still need no camera
        return _signals_pass(recording, source, config, topics, dbcs, clock)
    camera, camera_source = resolve_camera(recording, topics.streams, config.camera)
    total = frame_total(recording, topics.frames)
    say(self_check_label(config, total))
    check = drive_self_check(recording, topics.frames, config, camera)
    if isinstance(check, SelfCheck):  # its chosen backend, loaded, and its sample's labels
        stages = FrameStages(check.config(config), camera, reuse=check.stages)
    else:
        stages = FrameStages(config, camera)
    setup = PassSetup(topics, camera, stages, check, total)
    opened = sinks(setup)
    say("pass")
    drive = run_frames(recording, topics, stages, opened, config.workers, progress)
    skipped = list(recording.skipped)
    clock.lap()
    say("report: tables, plots, report")
    if drive.failed:
        skipped.append(Skipped("corrupt image", "; ".join(drive.failed[:5]), len(drive.failed)))
    frames, fps = drive.frames, drive.frames.frame_rate_hz()
    at_size = stages.camera_for(*stages.process_size(camera.width, camera.height))
    derived = drive_tables(
        frames,
        drive.can,
        dbcs,
        drive.gnss,
        config,
        kpi_segments(config, frames.t_ns, fps, segments),
        config.kpi.availability_params(fps),
        stages.corridor_unavailable,
        imu=drive.imu,
        length_cap_m=measurable_range_m(at_size),
        camera_facts=camera_facts(config.camera, camera_source, source),
    )
    checked = check.lines(stages.reused) if isinstance(check, SelfCheck) else [check]
    implausible = "" if not isinstance(check, SelfCheck) or check.plausible else check.reason
    notes = (*topics.streams.notes, f"camera: {camera_source}", *checked, *stages.notes)
    notes += (*derived.notes, *([unlike_training_data(implausible)] if implausible else []))
    facts = ReportFacts(
        source,
        len(frames),
        stages.backend_name,
        stages.corridor_unavailable,
        notes,
        (*skipped, *derived.lost),
        implausible,
        timing=timing_line(frames.stage_totals() | clock.pass_timings()),
    )
    return DriveOutcome(setup, derived, facts, drive.files, frames, clock)


def _signals_pass(
    recording: Any,
    source: Path,
    config: ReprocessConfig,
    topics: DriveTopics,
    dbcs: dict[str, LoadedDbc],
    clock: RunClock,
) -> DriveOutcome:
    """Collect CAN, GNSS and IMU, then build the tables that need no camera.

    The evaluation instants are a :data:`GRID_HZ` grid over the messages' span; SUPER, the
    corridor network and Hough are stated as not computed.
    """
    if not topics.can and not topics.streams.gnss:
        listing = ", ".join(f"{t.topic} ({t.msgtype})" for t in recording.topics()) or "none"
        raise DriveError(f"{source.name}: no camera, CAN or GNSS stream to reprocess ({listing})")
    drive = run_frames(recording, topics, None, [])
    skipped = list(recording.skipped)
    clock.lap()
    step = round(1e9 / GRID_HZ)
    t_ns = (
        np.arange(drive.span_ns[0], drive.span_ns[1] + 1, step, dtype=np.int64)
        if drive.span_ns is not None
        else np.zeros(0, dtype=np.int64)
    )
    size = max(1, round(config.kpi.window_s * GRID_HZ))
    segments = [Segment(s.start, s.stop, config.kpi.category) for s in windows(t_ns.size, size)]
    frames = no_camera_frames(t_ns)
    derived = drive_tables(
        frames,
        drive.can,
        dbcs,
        drive.gnss,
        config,
        segments,
        config.kpi.availability_params(GRID_HZ),
        NO_CAMERA,
        imu=drive.imu,
        camera=False,
    )
    facts = ReportFacts(  # the drive's notes (from its facts) say what was not computed
        source,
        len(frames),
        f"none ({NO_CAMERA})",
        NO_CAMERA,
        tuple(derived.notes),
        (*skipped, *derived.lost),
    )
    return DriveOutcome(PassSetup(topics), derived, facts, (), frames, clock)
