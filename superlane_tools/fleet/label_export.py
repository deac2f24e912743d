"""Pre-annotations of mined frames from the run's fitted lanes: TuSimple and CULane records.

The lines are drawn in the pixels of the saved image: the run's camera is resized to the
frame's recorded (source) size, not the processing size the fit ran at (``lanes.parquet``'s
``width`` / ``height``), so a 960x540 frame processed at 640x360 gets its lines at 960x540. At
most :data:`MAX_LANES` lines per frame (TuSimple's most): those nearest the ego lane.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from superlane_tools.camera.model import CameraModel
from superlane_tools.evaluation.culane import format_lines
from superlane_tools.evaluation.tusimple import TuSimpleRecord
from superlane_tools.evaluation.tusimple_export import (
    NO_POINT,
    TUSIMPLE_MAX_LINES,
    ExportOptions,
    fitted_frame,
    frame_record,
)

TUSIMPLE_ROWS = tuple(range(160, 720, 10))
"""TuSimple's ``h_samples`` for a 720-row image (scaled to other heights)."""
MAX_LANES = TUSIMPLE_MAX_LINES
"""Most lines written per frame (TuSimple labels at most 5): those with the smallest |offset|."""


def h_samples(height: int) -> list[float]:
    """Return TuSimple rows for an image ``height`` pixels tall (rows 160..710 scaled)."""
    return [round(r * height / 720.0) for r in TUSIMPLE_ROWS if r * height / 720.0 < height]


def pre_annotation(
    row: Mapping[str, Any], camera: CameraModel, raw_file: str, size: tuple[int, int]
) -> tuple[TuSimpleRecord, str]:
    """Return a frame's TuSimple record and its CULane ``.lines.txt`` text from its fit row.

    Args:
        row: The frame's ``lanes.parquet`` row (lines in the vehicle frame, metres).
        camera: The run's camera (any image size: it is resized).
        raw_file: The saved image's path in the label set.
        size: ``(width, height)`` of the saved image, pixels: the frame's recorded size.

    Lines outside the image are left out; at most :data:`MAX_LANES`, nearest the ego lane.
    """
    cam = camera if size == (camera.width, camera.height) else camera.resized(*size)
    rows = h_samples(size[1])
    options = ExportOptions(max_lines=MAX_LANES)
    record = frame_record(fitted_frame(row, raw_file), cam, rows, options)
    record = record._replace(raw_file=raw_file)
    return record, culane_text(record.lanes, rows)


def culane_text(lanes: Sequence[Sequence[float]], rows: Sequence[float]) -> str:
    """Return TuSimple lane columns as CULane ``.lines.txt`` text (bottom-up points)."""
    out = []
    for xs in lanes:
        pts = [(x, y) for x, y in zip(xs, rows, strict=True) if x != NO_POINT]
        if len(pts) >= 2:
            out.append(np.array(pts[::-1], dtype=np.float64))
    return format_lines(out)
