"""Pre-annotations of mined frames from the run's fitted lanes: TuSimple and CULane records."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from superlane_tools.camera.model import CameraModel
from superlane_tools.evaluation.culane import format_lines
from superlane_tools.evaluation.tusimple import TuSimpleRecord
from superlane_tools.evaluation.tusimple_export import (
    NO_POINT,
    ExportOptions,
    fitted_frame,
    frame_record,
)

TUSIMPLE_ROWS = tuple(range(160, 720, 10))
"""TuSimple's ``h_samples`` for a 720-row image (scaled to other heights)."""


def h_samples(height: int) -> list[float]:
    """Return TuSimple rows for an image ``height`` pixels tall (rows 160..710 scaled)."""
    return [round(r * height / 720.0) for r in TUSIMPLE_ROWS if r * height / 720.0 < height]


def pre_annotation(
    row: Mapping[str, Any], camera: CameraModel, raw_file: str
) -> tuple[TuSimpleRecord, str]:
    """Return a frame's TuSimple record and its CULane ``.lines.txt`` text from its fit row.

    The camera is resized to the row's image size; lines outside the image are left out.
    """
    size = (int(row["width"]), int(row["height"]))
    cam = camera if size == (camera.width, camera.height) else camera.resized(*size)
    rows = h_samples(size[1])
    record = frame_record(fitted_frame(row, raw_file), cam, rows, ExportOptions(max_lines=None))
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
