"""Exports of ``lanes.parquet``: TuSimple prediction JSON lines and KITTI ego-lane PNGs.

I/O only: the TuSimple rules (rows per frame, line caps, run time, colour and style) live in
:mod:`superlane_tools.evaluation.tusimple_export`, the ego-lane rasteriser in
:func:`superlane_tools.evaluation.kitti.ego_lane_mask`.
"""

from __future__ import annotations

import os
import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
from numpy.typing import NDArray

from superlane_tools.camera.model import CameraModel
from superlane_tools.commands.errors import PipelineError
from superlane_tools.errors import ConfigError
from superlane_tools.evaluation import format_record, load_jsonl
from superlane_tools.evaluation.tusimple_export import (
    ExportOptions,
    export_records,
    fitted_frame,
    rows_by_raw_file,
)
from superlane_tools.reporting import read_provenance, write_bytes_atomic, write_text_atomic
from superlane_tools.reporting.layout import LANES_FIT_SCHEMA


def parse_h_samples(spec: str) -> list[int]:
    """Parse ``START:STOP:STEP`` (stop inclusive, like TuSimple's 160:720:10 -> 160..710)."""
    try:
        parts = [int(v) for v in spec.split(":")]
    except ValueError as err:
        raise ConfigError(f"h-samples must be START:STOP:STEP integers, got {spec!r}") from err
    if len(parts) != 3 or parts[2] <= 0 or parts[1] <= parts[0] or parts[0] < 0:
        raise ConfigError(f"h-samples must be START:STOP:STEP with STOP > START >= 0, got {spec!r}")
    return list(range(parts[0], parts[1], parts[2]))


@dataclass(frozen=True)
class ExportResult:
    """Outcome of :func:`export_tusimple`: the JSON-lines file and its record count."""

    out: Path
    n_records: int


def export_tusimple(
    lanes_parquet: str | os.PathLike[str],
    camera: CameraModel,
    out: str | os.PathLike[str],
    options: ExportOptions,
    h_samples: Sequence[int] | None = None,
    tasks: str | os.PathLike[str] | None = None,
) -> ExportResult:
    """Write TuSimple prediction JSON lines from ``lanes.parquet``.

    See :mod:`superlane_tools.evaluation.tusimple_export` for the rules (rows per frame from
    ``tasks``, line caps, ``run_time``, colour and style).

    Raises:
        PipelineError: If the file is not a ``lanes.parquet`` written by ``slt lanes fit``.
        EvaluationError: If the task file is unreadable or lacks a frame.
    """
    src = Path(lanes_parquet)
    try:
        read_provenance(src)
        table = pq.read_table(src)
    except (OSError, pa.ArrowInvalid) as err:
        raise PipelineError(f"cannot read {src}: {err}") from err
    optional = {"c", "seg_time_ms"}  # files written before these columns existed
    missing = [
        n for n in LANES_FIT_SCHEMA.names if n not in table.column_names and n not in optional
    ]
    if missing:
        raise PipelineError(f"{src}: not a lanes.parquet file (missing {', '.join(missing)})")
    rows = table.to_pylist()
    cams: dict[tuple[int, int], CameraModel] = {}
    cameras = []
    for row in rows:
        size = (int(row["width"]), int(row["height"]))
        if size not in cams:
            cams[size] = camera if size == (camera.width, camera.height) else camera.resized(*size)
        cameras.append(cams[size])
    task_rows = rows_by_raw_file(load_jsonl(tasks)) if tasks is not None else None
    records = export_records(
        [fitted_frame(r) for r in rows], cameras, options, h_samples=h_samples, tasks=task_rows
    )
    text = "".join(f"{format_record(rec)}\n" for rec in records)
    return ExportResult(write_text_atomic(out, text), len(records))


KITTI_NAME = re.compile(r"^(um|umm|uu)_(\d+)$")


def export_kitti_ego_lane(
    lanes_parquet: str | os.PathLike[str], camera: CameraModel, out_dir: str | os.PathLike[str]
) -> ExportResult:
    """Write each frame's fitted ego lane as a KITTI submission PNG (255 inside, 0 outside).

    ``um_000000.png`` masks become ``um_lane_000000.png``; other names keep their stem. A frame
    without both ego lines gets an all-zero image (the benchmark needs every frame).

    Raises:
        PipelineError: If the file is not a ``lanes.parquet`` written by ``slt lanes fit``.
    """
    from superlane_tools.evaluation import ego_lane_mask

    src = Path(lanes_parquet)
    try:
        rows = pq.read_table(src).to_pylist()
    except (OSError, pa.ArrowInvalid) as err:
        raise PipelineError(f"cannot read {src}: {err}") from err
    if rows and "ego_left" not in rows[0]:
        raise PipelineError(f"{src}: not a lanes.parquet file (no ego_left)")
    root = Path(out_dir)
    for row in rows:
        frame = fitted_frame(row)
        size = (int(row["width"]), int(row["height"]))
        cam = camera if size == (camera.width, camera.height) else camera.resized(*size)
        left, right = int(row["ego_left"]), int(row["ego_right"])
        if left >= 0 and right >= 0:
            mask = ego_lane_mask(frame.lanes[left], frame.lanes[right], frame.b, cam, frame.c)
        else:
            mask = np.zeros((size[1], size[0]), dtype=bool)
        stem = Path(row["name"]).stem
        match = KITTI_NAME.match(stem)
        name = f"{match.group(1)}_lane_{match.group(2)}" if match else stem
        target = root / Path(row["name"]).parent / f"{name}.png"
        write_bytes_atomic(target, _png(np.where(mask, 255, 0).astype(np.uint8)))
    return ExportResult(root, len(rows))


def _png(image: NDArray[np.uint8]) -> bytes:
    import cv2  # late: heavy import

    ok, buf = cv2.imencode(".png", image)
    if not ok:
        raise PipelineError("cannot encode a PNG")
    return bytes(buf.tobytes())
