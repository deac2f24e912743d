"""Reprocess a recording without a camera: truth, the dynamics reference and Mobileye.

An engineer evaluating a production Mobileye against RTK has no camera stream. Everything that
needs no image is still computed -- the RTK (or plain GNSS) truth, the yaw-rate / speed
reference, the Mobileye comparison and its availability -- on a 15 Hz grid of evaluation times
over the GNSS/CAN span; SUPER, the corridor network and Hough are stated as not computed.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from superlane_tools.can import LoadedDbc
from superlane_tools.pipeline._gnss_sink import GnssSink
from superlane_tools.pipeline.errors import PipelineError
from superlane_tools.pipeline.reprocess._finalize import finalize
from superlane_tools.pipeline.reprocess.config import ReprocessConfig
from superlane_tools.pipeline.reprocess.lane_tracker import COV_KEYS
from superlane_tools.pipeline.reprocess.outputs import SCALAR_KEYS, availability_params
from superlane_tools.pipeline.reprocess.signals import CanFrames, ImuSamples
from superlane_tools.reporting import Provenance

GRID_HZ = 15.0
"""Evaluation rate without camera frames (the corridor paper's camera rate), Hz."""
NO_CAMERA = "no camera stream"


@dataclass(frozen=True)
class NoCameraStages:
    """What the report says about the image stages of a recording without a camera."""

    backend_name: str = f"none ({NO_CAMERA})"
    corridor_unavailable: str = NO_CAMERA


def reprocess_signals(
    rec: Any,
    src: Path,
    out: Path,
    cfg: ReprocessConfig,
    dbcs: dict[str, LoadedDbc],
    provenance: Provenance,
    topics: tuple[set[str], set[str], str],
    notes: list[str],
) -> tuple[list[Path], int, list[Any]]:
    """Collect CAN, GNSS and IMU, then write the tables and report that need no camera.

    Args:
        rec: The open recording.
        src: Its path (for the report title).
        out: Output folder.
        cfg: Configuration.
        dbcs: Loaded DBCs by name (``BUS=FILE`` names bind a bus).
        provenance: Provenance of the outputs.
        topics: CAN topics, IMU topics and the GNSS topic.
        notes: Report statements; extended.

    Returns:
        Files written, evaluation instants, and what was lost.

    Raises:
        PipelineError: If the recording has neither CAN nor GNSS.
    """
    can_topics, imu_topics, gnss_topic = topics
    if not can_topics and not gnss_topic:
        listing = ", ".join(f"{t.topic} ({t.msgtype})" for t in rec.topics()) or "none"
        raise PipelineError(f"no camera, CAN or GNSS stream to reprocess ({listing})")
    out.mkdir(parents=True, exist_ok=True)
    can, imu = CanFrames(), ImuSamples()
    gnss = GnssSink(out, None, provenance)
    first = last = None
    wanted = [*can_topics, *imu_topics, *([gnss_topic] if gnss_topic else [])]
    for msg in rec.messages(topics=wanted):
        if msg.topic in can_topics:
            can.add(msg)
        elif msg.topic in imu_topics:
            imu.add(msg)
        elif msg.topic == gnss_topic:
            gnss.add(msg)
        else:
            continue
        first = msg.log_time_ns if first is None else min(first, msg.log_time_ns)
        last = msg.log_time_ns if last is None else max(last, msg.log_time_ns)
    lost = list(rec.skipped)
    step = round(1e9 / GRID_HZ)
    t_ns = (
        np.arange(first, last + 1, step, dtype=np.int64)
        if first is not None and last is not None
        else np.zeros(0, dtype=np.int64)
    )
    n = t_ns.size
    scalars: dict[str, np.ndarray] = {k: np.full(n, np.nan) for k in (*SCALAR_KEYS, *COV_KEYS)}
    scalars["t_ns"] = t_ns
    scalars["super_track_ok"] = np.zeros(n, dtype=bool)
    notes.append(
        f"{NO_CAMERA}: SUPER, the corridor network and Hough not computed; truth, yaw-rate "
        f"reference and Mobileye evaluated on a {GRID_HZ:g} Hz grid"
    )
    kpi = cfg.kpi
    params = availability_params(kpi, GRID_HZ)
    from superlane_tools.corridor import windows
    from superlane_tools.corridor.availability import Segment

    size = max(1, round(kpi.window_s * GRID_HZ))
    segments = [Segment(s.start, s.stop, kpi.category) for s in windows(n, size)]
    written = finalize(
        out=out,
        config=cfg,
        provenance=provenance,
        scalars=scalars,
        segments=segments,
        params=params,
        can=can,
        dbcs=dbcs,
        gnss_rows=gnss.rows,
        examples=[],
        notes=notes,
        skipped=lost,
        recording=src,
        stages=NoCameraStages(),
        imu=imu,
        lost=lost,
        camera=False,
    )
    return written, n, lost
