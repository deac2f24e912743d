"""Reprocess a recording without a camera: truth, the dynamics reference and Mobileye.

An engineer evaluating a production Mobileye against RTK has no camera stream. Everything that
needs no image is still computed -- the RTK (or plain GNSS) truth, the yaw-rate / speed
reference, the Mobileye comparison and its availability -- on a 15 Hz grid of evaluation times
over the GNSS/CAN span; SUPER, the corridor network and Hough are stated as not computed.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import numpy as np

from superlane_tools.can import LoadedDbc
from superlane_tools.commands.errors import PipelineError
from superlane_tools.commands.reprocess.outputs import write_outputs
from superlane_tools.commands.reprocess.result import ReprocessResult
from superlane_tools.corridor import Segment, windows
from superlane_tools.drive.config import ReprocessConfig
from superlane_tools.drive.finalize import drive_tables
from superlane_tools.drive.loop import DriveTopics, run_frames
from superlane_tools.drive.record import no_camera_frames
from superlane_tools.reporting import Provenance, input_identity
from superlane_tools.reporting.drive_sections import ReportFacts

GRID_HZ = 15.0
"""Evaluation rate without camera frames (the corridor paper's camera rate), Hz."""
NO_CAMERA = "no camera stream"


def reprocess_signals(
    rec: Any,
    src: Path,
    out: Path,
    cfg: ReprocessConfig,
    loaded: tuple[dict[str, LoadedDbc], list[Path]],
    topics: DriveTopics,
    command: str,
) -> ReprocessResult:
    """Collect CAN, GNSS and IMU, then write the tables and report that need no camera.

    Args:
        rec: The open recording.
        src: Its path.
        out: Output folder.
        cfg: Configuration.
        loaded: DBCs by name (``BUS=FILE`` names bind a bus) and their files.
        topics: The CAN, IMU and GNSS topics to read.
        command: Command line for the provenance.

    Returns:
        Status, files written, report notes, what was lost and the seconds it took.

    Raises:
        PipelineError: If the recording has neither CAN nor GNSS.
    """
    t_start = time.perf_counter()
    dbcs, dbc_paths = loaded
    if not topics.can and not topics.streams.gnss:
        listing = ", ".join(f"{t.topic} ({t.msgtype})" for t in rec.topics()) or "none"
        raise PipelineError(f"{src.name}: no camera, CAN or GNSS stream to reprocess ({listing})")
    provenance = Provenance(
        command=command or f"reprocess({src.name!r})",
        inputs=(input_identity(src), *(input_identity(p) for p in dbc_paths)),
        config=cfg.to_dict(),
    )
    out.mkdir(parents=True, exist_ok=True)
    drive = run_frames(rec, topics, None, [])
    skipped = list(rec.skipped)
    step = round(1e9 / GRID_HZ)
    t_ns = (
        np.arange(drive.span_ns[0], drive.span_ns[1] + 1, step, dtype=np.int64)
        if drive.span_ns is not None
        else np.zeros(0, dtype=np.int64)
    )
    notes: list[str] = []  # the drive's notes (from its facts) say what was not computed
    size = max(1, round(cfg.kpi.window_s * GRID_HZ))
    segments = [Segment(s.start, s.stop, cfg.kpi.category) for s in windows(t_ns.size, size)]
    frames = no_camera_frames(t_ns)
    derived = drive_tables(
        frames,
        drive.can,
        dbcs,
        drive.gnss,
        cfg,
        segments,
        cfg.kpi.availability_params(GRID_HZ),
        NO_CAMERA,
        imu=drive.imu,
        camera=False,
    )
    notes += derived.notes
    skipped += derived.lost
    facts = ReportFacts(
        src, len(frames), f"none ({NO_CAMERA})", NO_CAMERA, tuple(notes), tuple(skipped)
    )
    written = write_outputs(out, derived, provenance, cfg, [], facts)
    return ReprocessResult(
        status="partial" if skipped else "ok",
        skipped=tuple(skipped),
        outputs=tuple(written),
        timings={"total": time.perf_counter() - t_start},
        notes=tuple(notes),
    )
