"""``reprocess``: one streaming pass over a drive into every table, plot and report.

Frames go through a bounded thread pool (decode, segmentation, corridor network, Hough) and then,
in order, the warm-started SUPER fit and the corridor's three-frame mean; per-frame rows are
streamed to Parquet. CAN and GNSS are small and collected during the same pass, then turned into
speed, yaw rate, Mobileye lanes and the RTK curvature truth aligned on the frame times.
"""

from __future__ import annotations

import math
import os
import time
from collections import deque
from collections.abc import Callable
from concurrent.futures import Future, ThreadPoolExecutor
from contextlib import ExitStack
from dataclasses import dataclass, field
from importlib.resources import files
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pyarrow as pa

from superlane_tools.can import LoadedDbc, load_dbc
from superlane_tools.corridor import AvailabilityParams, Segment, windows
from superlane_tools.lanes import LaneFit
from superlane_tools.pipeline._gnss_sink import GnssSink
from superlane_tools.pipeline.errors import PipelineError
from superlane_tools.pipeline.reprocess import outputs as tables
from superlane_tools.pipeline.reprocess._examples import example_frame
from superlane_tools.pipeline.reprocess._finalize import finalize
from superlane_tools.pipeline.reprocess.config import ReprocessConfig
from superlane_tools.pipeline.reprocess.inputs import resolve_camera, select
from superlane_tools.pipeline.reprocess.lane_tracker import COV_INDEX, COV_KEYS
from superlane_tools.pipeline.reprocess.signals import CanFrames
from superlane_tools.pipeline.reprocess.stages import Finished, FrameStages, Prepared
from superlane_tools.recording.open import open_recording
from superlane_tools.records import Skipped
from superlane_tools.reporting import ParquetStreamWriter, Provenance, input_identity
from superlane_tools.reporting.plots import ExampleFrame

Progress = Callable[[int, int | None], None]
"""Progress callback ``(frames done, frames total or None)``."""
FLUSH_ROWS = 256
SHIPPED_DBCS = ("slt_vehicle.dbc", "slt_mobileye_lanes.dbc")


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


def shipped_dbc(name: str) -> Path:
    """Return the path of a DBC shipped in ``superlane_tools/data/dbc``."""
    return Path(str(files("superlane_tools") / "data" / "dbc" / name))


def _example_indices(total: int | None, count: int) -> set[int]:
    if count <= 0:
        return set()
    if not total:
        return {10 * (k + 1) for k in range(count)}
    return {int(total * (k + 1) / (count + 1)) for k in range(count)}


class _Streamer:
    """Writes the streamed per-frame tables and keeps the per-frame scalars."""

    def __init__(self, out: Path, provenance: Provenance, stack: ExitStack) -> None:
        specs = {
            "frames": tables.FRAMES_SCHEMA,
            "lanes": tables.LANES_SCHEMA,
            "corridor": tables.CORRIDOR_SCHEMA,
            "baseline": tables.BASELINE_SCHEMA,
        }
        self.writers = {
            name: stack.enter_context(
                ParquetStreamWriter(out / f"{name}.parquet", schema, provenance)
            )
            for name, schema in specs.items()
        }
        self.rows: dict[str, list[dict[str, Any]]] = {name: [] for name in specs}
        self.scalars: dict[str, list[float]] = {
            k: []
            for k in (
                "t_ns",
                "super_w",
                "super_l",
                "net_w",
                "net_l",
                "hough_w",
                "hough_l",
                "super_curv",
                "super_centre",
                "super_lane_width",
                "super_ahead",
                "super_a1",
                "super_b",
                "super_near",
                "super_far",
                "super_track_ok",
                *COV_KEYS,
                "ok",
            )
        }

    def add(self, done: Finished, corridor_status: str, mean_frames: int, max_slope: float) -> None:
        for name, row in tables.frame_rows(done, corridor_status, mean_frames).items():
            self.rows[name].append(row)
        if len(self.rows["frames"]) >= FLUSH_ROWS:
            self.flush()
        prep, s = done.prepared, self.scalars
        h = prep.hough
        s["t_ns"].append(prep.log_time_ns)
        s["super_w"].append(done.super_corridor.width_m)
        s["super_l"].append(done.super_corridor.length_m)
        s["net_w"].append(done.net_corridor.width_m)
        s["net_l"].append(done.net_corridor.length_m)
        s["hough_w"].append(h.width_m if h is not None and h.ok else math.nan)
        s["hough_l"].append(h.range_m if h is not None and h.ok else math.nan)
        s["super_curv"].append(done.fit.curvature if done.fit.ok else math.nan)
        centre, width, ahead = _ego_geometry(done.fit)
        s["super_centre"].append(centre)
        s["super_lane_width"].append(width)
        s["super_ahead"].append(ahead)
        near, far, usable = _track_input(done.fit, max_slope)
        s["super_a1"].append(done.fit.a1 if done.fit.ok else math.nan)
        s["super_b"].append(done.fit.b if done.fit.ok else math.nan)
        s["super_near"].append(near)
        s["super_far"].append(far)
        s["super_track_ok"].append(float(usable))
        cov = done.fit.shared_cov if done.fit.ok else None
        for key, (i, j) in zip(COV_KEYS, COV_INDEX, strict=True):
            s[key].append(float(cov[i, j]) if cov is not None else math.nan)
        s["ok"].append(float(not prep.error))

    def flush(self) -> None:
        for name, rows in self.rows.items():
            if rows:
                self.writers[name].write(pa.Table.from_pylist(rows, self.writers[name].schema))
                rows.clear()


def _ego_geometry(fit: LaneFit) -> tuple[float, float, float]:
    """Return the lane-grid centre offset and lane width (m) and the middle of the support (m).

    The centre offset is the circular mean, with period one lane width, of every fitted line's
    offset shifted by half a width (nearer lines weigh more): it needs no choice of ego pair,
    so it stays continuous while the vehicle straddles a line during a lane change.
    """
    if not fit.ok or fit.ego_left < 0 or fit.ego_right < 0:
        return math.nan, math.nan, math.nan
    left, right = fit.lanes[fit.ego_left], fit.lanes[fit.ego_right]
    width = left.offset_m - right.offset_m
    near = max(left.range_min_m, right.range_min_m)
    far = min(left.range_max_m, right.range_max_m)
    ahead = 0.5 * (near + far) if far > near else math.nan
    if width <= 1.0:
        return math.nan, math.nan, ahead
    offsets = np.array([lane.offset_m for lane in fit.lanes]) - 0.5 * width
    weights = np.exp(-np.abs(offsets) / width)
    phase = np.angle(np.sum(weights * np.exp(2j * np.pi * offsets / width)))
    return float(width * phase / (2 * np.pi)), width, ahead


def _track_input(fit: LaneFit, max_slope: float) -> tuple[float, float, bool]:
    """Return the ego lines' common supported range (m) and whether the tracker may use the fit.

    A fit is a tracker measurement when it has both ego lines with a common range and its slope
    ``|b|`` is below ``max_slope`` (at the optimiser's bound the view has collapsed).
    """
    if not fit.ok or fit.ego_left < 0 or fit.ego_right < 0:
        return math.nan, math.nan, False
    left, right = fit.lanes[fit.ego_left], fit.lanes[fit.ego_right]
    near = max(left.range_min_m, right.range_min_m)
    far = min(left.range_max_m, right.range_max_m)
    usable = far > near and abs(fit.b) < max_slope and math.isfinite(fit.curvature)
    return near, far, usable


def _load_dbcs(config: ReprocessConfig) -> tuple[dict[str, LoadedDbc], list[Path]]:
    paths = [Path(p) for p in config.can.dbcs] or [shipped_dbc(n) for n in SHIPPED_DBCS]
    return {p.name: load_dbc(p) for p in paths}, paths


def _segments(config: ReprocessConfig, t_ns: np.ndarray, fps: float) -> list[Segment]:
    n = len(t_ns)
    if n == 0:
        return []
    if not config.kpi.manifest:
        size = max(1, round(config.kpi.window_s * fps))
        return [Segment(s.start, s.stop, config.kpi.category) for s in windows(n, size)]
    import yaml

    from superlane_tools.errors import ConfigError

    try:
        items = yaml.safe_load(Path(config.kpi.manifest).read_text(encoding="utf-8")) or []
    except (OSError, yaml.YAMLError) as err:
        raise ConfigError(f"cannot read manifest {config.kpi.manifest}: {err}") from err
    rel = (t_ns - t_ns[0]) / 1e9
    segs = []
    for item in items:
        try:
            start = int(np.searchsorted(rel, float(item["start_s"]), "left"))
            stop = int(np.searchsorted(rel, float(item["stop_s"]), "left"))
            category = str(item.get("category", ""))
        except (KeyError, TypeError, ValueError) as err:
            raise ConfigError(f"{config.kpi.manifest}: bad segment {item!r}") from err
        if stop > start:
            segs.append(Segment(start, stop, category))
    return segs


def reprocess(
    recording_path: str | os.PathLike[str],
    out_dir: str | os.PathLike[str],
    config: ReprocessConfig | None = None,
    progress: Progress | None = None,
    command: str = "",
) -> ReprocessResult:
    """Reprocess one drive into tables, plots, a report and Foxglove annotations.

    Args:
        recording_path: A recording :func:`~superlane_tools.recording.open_recording` opens.
        out_dir: Output folder (created).
        config: Configuration (defaults when None).
        progress: Called as ``progress(frames_done, frames_total_or_None)``.
        command: Command line for the provenance.

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
    dbcs, dbc_paths = _load_dbcs(cfg)
    with open_recording(src) as rec:
        streams = select(rec.topics(), cfg)
        if not streams.frames:
            listing = ", ".join(f"{t.topic} ({t.msgtype})" for t in rec.topics()) or "none"
            raise PipelineError(f"{src.name}: no camera image topic to reprocess ({listing})")
        camera, camera_source = resolve_camera(rec, src, streams, cfg.camera)
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
        provenance = Provenance(
            command=command or f"reprocess({src.name!r})",
            inputs=(input_identity(src), *(input_identity(p) for p in dbc_paths)),
            config=config_data,
            models=stages.models,
        )
        can = CanFrames()
        gnss = GnssSink(out, None, provenance)
        examples: list[ExampleFrame] = []
        failed: list[str] = []
        out.mkdir(parents=True, exist_ok=True)
        with ExitStack() as stack:
            streamer = _Streamer(out, provenance, stack)
            from superlane_tools.pipeline.reprocess._live import LiveOutputs

            live = stack.enter_context(LiveOutputs(out, cfg, streams.frames, stages))
            pool = stack.enter_context(ThreadPoolExecutor(cfg.workers, "slt-reprocess"))
            pending: deque[Future[Prepared]] = deque()
            done_count = 0

            def handle(prep: Prepared) -> None:
                nonlocal done_count
                done = stages.finish(prep)
                streamer.add(
                    done,
                    stages.corridor_unavailable,
                    cfg.corridor.mean_frames,
                    stages.max_slope,
                )
                live.add(done)
                if prep.error:
                    failed.append(f"frame {prep.index}: {prep.error}")
                if prep.index in wanted_examples and prep.image is not None:
                    examples.append(example_frame(done))
                done_count += 1
                if progress is not None:
                    progress(done_count, total)

            topics = [t for t in (streams.frames, streams.can, streams.gnss) if t]
            index = 0
            for msg in rec.messages(topics=topics):
                if msg.topic == streams.frames:
                    pending.append(pool.submit(stages.prepare, index, msg))
                    index += 1
                    while len(pending) > 2 * cfg.workers:
                        handle(pending.popleft().result())
                elif msg.topic == streams.can:
                    can.add(msg)
                elif msg.topic == streams.gnss:
                    gnss.add(msg)
            while pending:
                handle(pending.popleft().result())
            streamer.flush()
        skipped = list(rec.skipped)
    t_pass, cpu_pass = time.perf_counter(), time.process_time()
    if failed:
        skipped.append(Skipped("corrupt image", "; ".join(failed[:5]), len(failed)))
    written = [w.path for w in streamer.writers.values()] + live.paths
    scal = {k: np.asarray(v) for k, v in streamer.scalars.items()}
    t_ns = scal["t_ns"].astype(np.int64)
    steps = np.diff(t_ns)[np.diff(t_ns) > 0]  # frames may share log times (batched bridges)
    fps = 1e9 / float(np.median(steps)) if steps.size else 15.0
    segments = _segments(cfg, t_ns, fps)
    kpi = cfg.kpi
    params = AvailabilityParams(
        min_width_m=kpi.min_width_m,
        max_width_m=kpi.max_width_m,
        time_gap_s=kpi.time_gap_s,
        max_outage_frames=kpi.max_outage_frames,
        window_frames=max(1, round(kpi.window_s * fps)),
        frame_rate_hz=fps,
    )
    written += finalize(
        out=out,
        config=cfg,
        provenance=provenance,
        scalars=scal,
        segments=segments,
        params=params,
        can=can,
        dbcs=dbcs,
        gnss_rows=gnss.rows,
        examples=examples,
        notes=notes,
        skipped=skipped,
        recording=src,
        stages=stages,
    )
    t_end, cpu_end = time.perf_counter(), time.process_time()
    timings = _timings(out / "frames.parquet")
    timings["pass_wall"] = t_pass - t_start
    timings["post"] = t_end - t_pass
    timings["total"] = t_end - t_start
    timings["cpu_pass"] = cpu_pass - cpu_start
    timings["cpu_post"] = cpu_end - cpu_pass
    timings["cpu_total"] = cpu_end - cpu_start
    n = len(t_ns)
    return ReprocessResult(
        status="partial" if skipped else "ok",
        skipped=tuple(skipped),
        outputs=tuple(written),
        timings=timings,
        frames=n,
        notes=tuple(notes),
        frames_per_s=n / timings["total"] if timings["total"] > 0 else 0.0,
    )


def _timings(frames_path: Path) -> dict[str, float]:
    """Seconds per stage: wall (``<stage>``) and thread CPU (``cpu_<stage>``), summed."""
    cols = [f"{s}_ms" for s in tables.STAGES] + [f"{s}_cpu_ms" for s in tables.STAGES]
    frame = pd.read_parquet(frames_path, columns=cols)
    out = {s: float(frame[f"{s}_ms"].sum()) / 1e3 for s in tables.STAGES}
    out.update({f"cpu_{s}": float(frame[f"{s}_cpu_ms"].sum()) / 1e3 for s in tables.STAGES})
    return out
