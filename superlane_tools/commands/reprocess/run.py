"""``reprocess``: one streaming pass over a drive into every table, plot and report.

1. Pick the streams, resolve the camera, build the stages. 2. Stream the recording once: frames
go through a bounded thread pool (decode, segmentation, corridor network, Hough), then in order
through the warm-started SUPER fit and the corridor mean, into the per-frame tables and the
drive's typed record; CAN and GNSS (small) are collected. 3. Turn the record plus CAN and GNSS
into the drive's tables (a pure function), then write them with plots and the report.
"""

from __future__ import annotations

import os
import time
from collections import deque
from collections.abc import Sequence
from concurrent.futures import Future, ThreadPoolExecutor
from contextlib import ExitStack
from dataclasses import asdict
from pathlib import Path

from superlane_tools.can import load_dbcs
from superlane_tools.can.collect import CanFrames
from superlane_tools.commands.reprocess._live import LiveOutputs
from superlane_tools.commands.reprocess._threads import single_native_threads
from superlane_tools.commands.reprocess.outputs import streamed_files, write_outputs
from superlane_tools.commands.reprocess.result import Progress, ReprocessResult
from superlane_tools.corridor import TimeSegment
from superlane_tools.drive import ReportFacts, ReprocessConfig
from superlane_tools.drive.examples import example_frame, example_indices
from superlane_tools.drive.finalize import drive_tables, kpi_segments
from superlane_tools.drive.record import DriveRecorder
from superlane_tools.drive.signals import ImuSamples
from superlane_tools.drive.stages import FrameStages, Prepared
from superlane_tools.recording.calibration import resolve_camera
from superlane_tools.recording.open import open_recording
from superlane_tools.recording.streams import select_one_each, topics_of_type
from superlane_tools.recording.video import decode_video
from superlane_tools.records import Skipped
from superlane_tools.reporting import Provenance, input_identity
from superlane_tools.reporting.gnss_sink import GnssSink
from superlane_tools.reporting.plots import example_plot

CAN_TYPE, IMU_TYPE = "can_msgs/msg/Frame", "sensor_msgs/msg/Imu"
"""Every topic of these types is read unless ``topics.can`` / ``topics.imu`` names one."""


@single_native_threads()  # BLAS and OpenCV pools at one thread: our workers fill the cores
def reprocess(
    recording_path: str | os.PathLike[str],
    out_dir: str | os.PathLike[str],
    config: ReprocessConfig | None = None,
    progress: Progress | None = None,
    command: str = "",
    segments: Sequence[TimeSegment] | None = None,
) -> ReprocessResult:
    """Reprocess one drive into tables, plots, a report and Foxglove annotations.

    Args:
        recording_path: A recording :func:`~superlane_tools.recording.open_recording` opens.
        out_dir: Output folder (created).
        config: Configuration (defaults when None).
        progress: Called as ``progress(frames_done, frames_total_or_None)``.
        command: Command line for the provenance.
        segments: KPI sequences of the drive (None: ``kpi.manifest``, else windows).

    Returns:
        Status, outputs, skipped data, timings and notes.

    Raises:
        RecordingError: If the input is not a recording.
        PipelineError: If it has no camera images.
        UsageError: For a bad configuration, missing calibration or unusable model.
    """
    cfg = config or ReprocessConfig()
    src, out = Path(recording_path), Path(out_dir)
    t_start, cpu_start = time.perf_counter(), time.process_time()
    dbcs, dbc_paths = load_dbcs(cfg.can.dbcs)
    with open_recording(src) as rec:
        # 1. Streams, camera and stages.
        streams = select_one_each(rec.topics(), asdict(cfg.topics))
        listed = rec.topics()  # every CAN bus unless one is configured; the IMU
        can_topics = {streams.can} if cfg.topics.can else topics_of_type(listed, CAN_TYPE)
        imu_topics = {cfg.topics.imu} if cfg.topics.imu else topics_of_type(listed, IMU_TYPE)
        if not streams.frames:  # truth, dynamics and Mobileye still need no camera
            from superlane_tools.commands.reprocess._signals_only import reprocess_signals

            found = (can_topics, imu_topics, streams.gnss)
            return reprocess_signals(rec, src, out, cfg, (dbcs, dbc_paths), found, command)
        camera, camera_source = resolve_camera(rec, streams, cfg.camera)
        stages = FrameStages(cfg, camera)
        notes = [*streams.notes, f"camera: {camera_source}", *stages.notes]
        total = next((t.message_count for t in rec.topics() if t.topic == streams.frames), None)
        wanted_examples = example_indices(total, cfg.output.plots and cfg.output.example_frames)
        config_data = cfg.to_dict()
        config_data["resolved"] = {
            "streams": streams._asdict(),
            "camera": camera.to_dict(),
            "segmentation_backend": stages.backend_name,
            "corridor_unavailable": stages.corridor_unavailable,
        }
        if segments is not None:
            config_data["resolved"]["segments"] = [s._asdict() for s in segments]
        provenance = Provenance(
            command=command or f"reprocess({src.name!r})",
            inputs=(input_identity(src), *(input_identity(p) for p in dbc_paths)),
            config=config_data,
            models=stages.models,
        )
        # 2. One streaming pass: frames through the stages, CAN and GNSS collected.
        can, imu = CanFrames(), ImuSamples()
        gnss = GnssSink(None, None, provenance)
        example_pngs: list[Future[Path]] = []  # drawn on their own thread during the pass
        failed: list[str] = []
        out.mkdir(parents=True, exist_ok=True)
        with ExitStack() as stack:
            recorder = DriveRecorder(
                streamed_files(out),
                provenance,
                stack,
                stages.corridor_unavailable,
                cfg.corridor.mean_frames,
                stages.max_slope,
            )
            live = stack.enter_context(LiveOutputs(out, cfg, streams.frames))
            pool = stack.enter_context(ThreadPoolExecutor(cfg.workers, "slt-reprocess"))
            plotter = stack.enter_context(ThreadPoolExecutor(1, "slt-example-plots"))
            pending: deque[Future[Prepared]] = deque()
            done_count = 0

            def handle(prep: Prepared) -> None:
                nonlocal done_count
                done = stages.finish(prep)
                recorder.add(done)
                live.add(done)
                if prep.error:
                    failed.append(f"frame {prep.index}: {prep.error}")
                if prep.index in wanted_examples and prep.image is not None:
                    example = example_frame(done)
                    example_pngs.append(plotter.submit(example_plot, example, out / "plots"))
                done_count += 1
                if progress is not None:
                    progress(done_count, total)

            wanted = [t for t in (streams.frames, streams.gnss, *can_topics, *imu_topics) if t]
            index = 0
            for msg in decode_video(rec.messages(topics=wanted)):
                if msg.topic == streams.frames:
                    pending.append(pool.submit(stages.prepare, index, msg))
                    index += 1
                    for prep in stages.due(pending, cfg.workers):
                        handle(prep)
                elif msg.topic in can_topics:
                    can.add(msg)
                elif msg.topic in imu_topics:
                    imu.add(msg)
                elif msg.topic == streams.gnss:
                    gnss.add(msg)
            while pending:
                handle(pending.popleft().result())
            recorder.flush()
        skipped = list(rec.skipped)
    t_pass, cpu_pass = time.perf_counter(), time.process_time()
    if failed:
        skipped.append(Skipped("corrupt image", "; ".join(failed[:5]), len(failed)))
    # 3. The drive's tables from its record, CAN and GNSS; then plots and the report.
    frames = recorder.record()
    fps = frames.frame_rate_hz()
    derived = drive_tables(
        frames,
        can,
        dbcs,
        gnss.fixes(),
        cfg,
        kpi_segments(cfg, frames.t_ns, fps, segments),
        cfg.kpi.availability_params(fps),
        stages.corridor_unavailable,
        imu=imu,
    )
    notes += derived.notes
    skipped += derived.lost
    facts = ReportFacts(
        src,
        len(frames),
        stages.backend_name,
        stages.corridor_unavailable,
        tuple(notes),
        tuple(skipped),
    )
    written = [*recorder.paths, *live.paths]
    rendered = [f.result() for f in example_pngs]
    written += write_outputs(out, derived, provenance, cfg, [], facts, rendered)
    t_end, cpu_end = time.perf_counter(), time.process_time()
    timings = frames.stage_totals() | {
        "pass_wall": t_pass - t_start,
        "post": t_end - t_pass,
        "total": t_end - t_start,
        "cpu_pass": cpu_pass - cpu_start,
        "cpu_post": cpu_end - cpu_pass,
        "cpu_total": cpu_end - cpu_start,
    }
    n = len(frames)
    return ReprocessResult(
        status="partial" if skipped else "ok",
        skipped=tuple(skipped),
        outputs=tuple(written),
        timings=timings,
        frames=n,
        notes=tuple(notes),
        frames_per_s=n / timings["total"] if timings["total"] > 0 else 0.0,
    )
