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
from collections.abc import Callable, Sequence
from concurrent.futures import Future, ThreadPoolExecutor
from contextlib import ExitStack
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from superlane_tools.can import ALL_BUSES, LoadedDbc, load_dbc, parse_dbc_spec, shipped_dbcs
from superlane_tools.can.collect import CanFrames
from superlane_tools.commands.reprocess._examples import example_frame
from superlane_tools.commands.reprocess._finalize import ReportFacts, drive_tables, write_outputs
from superlane_tools.commands.reprocess._live import LiveOutputs
from superlane_tools.commands.reprocess._threads import single_native_threads
from superlane_tools.commands.reprocess.config import ReprocessConfig, load_manifest
from superlane_tools.commands.reprocess.record import DriveRecorder
from superlane_tools.commands.reprocess.signals import ImuSamples
from superlane_tools.commands.reprocess.stages import FrameStages, Prepared
from superlane_tools.corridor import Segment, TimeSegment, segments_at_times, windows
from superlane_tools.recording.calibration import resolve_camera
from superlane_tools.recording.open import open_recording
from superlane_tools.recording.streams import select_one_each
from superlane_tools.recording.video import decode_video
from superlane_tools.records import Skipped, TopicInfo
from superlane_tools.reporting import Provenance, input_identity
from superlane_tools.reporting.gnss_sink import GnssSink
from superlane_tools.reporting.plots import example_plot

Progress = Callable[[int, int | None], None]
"""Progress callback ``(frames done, frames total or None)``."""


@dataclass(frozen=True)
class ReprocessResult:
    """Outcome of :func:`reprocess`.

    Attributes:
        status: ``ok``, or ``partial`` when input data was lost or skipped.
        skipped: What was lost (reading errors, undecodable frames).
        outputs: Files written.
        timings: Seconds per stage: wall time (``<stage>``, summed over worker threads) and
            thread CPU time (``cpu_<stage>``); ``pass_wall`` / ``post`` / ``total`` wall time of
            the streaming pass, of the tables, plots and report, and of both; ``cpu_pass`` /
            ``cpu_post`` / ``cpu_total`` the process CPU time (all threads) of the same.
        frames: Camera frames processed.
        notes: Missing streams and fallbacks, as stated in the report.
        frames_per_s: Frames per second of wall time, end to end.
    """

    status: str
    skipped: tuple[Skipped, ...]
    outputs: tuple[Path, ...]
    timings: dict[str, float] = field(default_factory=dict)
    frames: int = 0
    notes: tuple[str, ...] = ()
    frames_per_s: float = 0.0


def _example_indices(total: int | None, count: int) -> set[int]:
    if count <= 0:
        return set()
    if not total:
        return {10 * (k + 1) for k in range(count)}
    return {int(total * (k + 1) / (count + 1)) for k in range(count)}


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
    with single_native_threads():
        return _reprocess(
            Path(recording_path),
            Path(out_dir),
            config or ReprocessConfig(),
            progress,
            command,
            segments,
        )


def _reprocess(
    src: Path,
    out: Path,
    cfg: ReprocessConfig,
    progress: Progress | None,
    command: str,
    segments: Sequence[TimeSegment] | None,
) -> ReprocessResult:
    t_start, cpu_start = time.perf_counter(), time.process_time()
    dbcs, dbc_paths = load_dbcs(cfg.can.dbcs)
    with open_recording(src) as rec:
        # 1. Streams, camera and stages.
        streams = select_one_each(rec.topics(), asdict(cfg.topics))
        listed = rec.topics()  # every CAN bus unless one is configured; the IMU
        can_topics = {streams.can} if cfg.topics.can else _typed(listed, "can_msgs/msg/Frame")
        imu_topics = {cfg.topics.imu} if cfg.topics.imu else _typed(listed, "sensor_msgs/msg/Imu")
        if not streams.frames:  # truth, dynamics and Mobileye still need no camera
            from superlane_tools.commands.reprocess._signals_only import reprocess_signals

            found = (can_topics, imu_topics, streams.gnss)
            done = reprocess_signals(rec, src, out, cfg, (dbcs, dbc_paths), found, command)
            return ReprocessResult(
                status="partial" if done.skipped else "ok",
                skipped=done.skipped,
                outputs=done.outputs,
                timings={"total": done.seconds},
                notes=done.notes,
            )
        camera, camera_source = resolve_camera(rec, streams, cfg.camera)
        stages = FrameStages(cfg, camera)
        notes = [*streams.notes, f"camera: {camera_source}", *stages.notes]
        total = next((t.message_count for t in rec.topics() if t.topic == streams.frames), None)
        wanted_examples = _example_indices(
            total, cfg.output.example_frames if cfg.output.plots else 0
        )
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
        # Example plots (matplotlib, a fixed ~1.5 s of CPU per drive) are drawn on their own
        # thread while the pass runs, instead of after it with one core idle.
        example_pngs: list[Future[Path]] = []
        failed: list[str] = []
        out.mkdir(parents=True, exist_ok=True)
        with ExitStack() as stack:
            recorder = DriveRecorder(
                out,
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
                    while len(pending) > 2 * cfg.workers:
                        handle(pending.popleft().result())
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
    t_ns = frames.t_ns
    steps = np.diff(t_ns)[np.diff(t_ns) > 0]  # frames may share log times (batched bridges)
    fps = 1e9 / float(np.median(steps)) if steps.size else 15.0
    derived = drive_tables(
        frames,
        can,
        dbcs,
        gnss.rows,
        cfg,
        _kpi_segments(cfg, t_ns, fps, segments),
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
    timings = frames.stage_totals()
    timings["pass_wall"] = t_pass - t_start
    timings["post"] = t_end - t_pass
    timings["total"] = t_end - t_start
    timings["cpu_pass"] = cpu_pass - cpu_start
    timings["cpu_post"] = cpu_end - cpu_pass
    timings["cpu_total"] = cpu_end - cpu_start
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


def load_dbcs(specs: Sequence[str]) -> tuple[dict[str, LoadedDbc], list[Path]]:
    """Load ``[BUS=]FILE`` DBCs (none: the shipped ones); names ``BUS=file`` bind a bus."""
    parsed = [parse_dbc_spec(p) for p in specs]
    if not parsed:
        return {p.name: load_dbc(p) for p in shipped_dbcs()}, list(shipped_dbcs())
    names = [s.path.name if s.bus == ALL_BUSES else f"{s.bus}={s.path.name}" for s in parsed]
    loaded = {n: load_dbc(s.path) for n, s in zip(names, parsed, strict=True)}
    return loaded, [s.path for s in parsed]


def _typed(topics: Sequence[TopicInfo], msgtype: str) -> set[str]:
    """Return the topics of one message type (ROS 1 / ROS 2 spellings alike)."""
    short = msgtype.replace("/msg/", "/")
    return {t.topic for t in topics if t.msgtype in (msgtype, short)}


def _kpi_segments(
    config: ReprocessConfig, t_ns: np.ndarray, fps: float, given: Sequence[TimeSegment] | None
) -> list[Segment]:
    """Return the KPI sequences as frame ranges: given, from the manifest, or windows."""
    if given is None and config.kpi.manifest:
        given = load_manifest(config.kpi.manifest)
    if given is not None:
        return segments_at_times(t_ns, given)
    size = max(1, round(config.kpi.window_s * fps))
    return [Segment(s.start, s.stop, config.kpi.category) for s in windows(len(t_ns), size)]
