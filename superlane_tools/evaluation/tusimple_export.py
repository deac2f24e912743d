"""Turn fitted lanes into TuSimple prediction records (pure: lanes in, records out).

Rules (``slt lanes export-tusimple``):

* **Rows.** Each frame is sampled at its own ``h_samples``: those of the task or label entry
  with the same ``raw_file`` when a task file is given (TuSimple's ``test_tasks.json``, or the
  label file itself; 0313 clips use rows 240..710, the others 160..710), else one
  ``START:STOP:STEP`` for all frames.
* **Geometry.** A line is drawn on the frame's road ``z = b x + c x^2`` (the vertical-curve term
  ``c`` is used when the fit estimated it) inside its supported range; rows outside the range
  or the image are ``-2``.
* **Line count.** LaneEval zeroes a frame with more than ``n_gt + 2`` lines, so at most
  ``max_lines`` are written (default 5, TuSimple's most lines per frame): those nearest the
  camera (smallest ``|offset|``). With a known lane count ``n_lanes`` (from a map), the
  ``n_lanes + 1`` adjacent lines with the most supporting pixels are kept instead (a smaller
  ``max_lines`` still applies).
* **Run time.** ``run_time`` = segmentation time + fit time of the frame (milliseconds) when both
  were measured, else the fit time.
* **Attributes** (an extension of the format, ignored by LaneEval): per-lane ``color``
  (``white``/``yellow``/``unknown``) and ``style`` (``solid``/``dashed``/``double``/``unknown``).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import PurePosixPath
from typing import Any

import numpy as np

from superlane_tools.camera.model import CameraModel
from superlane_tools.evaluation.errors import EvaluationError
from superlane_tools.evaluation.tusimple import TuSimpleRecord
from superlane_tools.lanes import Lane, lanes_at_rows
from superlane_tools.lanes.table import lanes_from_row

NO_POINT = -2
"""x written where a line has no point on a row."""
TUSIMPLE_MAX_LINES = 5
"""Most lines TuSimple labels per frame (and the default cap of the export)."""


@dataclass(frozen=True)
class ExportOptions:
    """How fitted lanes become TuSimple lines.

    Attributes:
        max_lines: Most lines per frame (None: no cap).
        n_lanes: Known number of lanes of the road (None: unknown); keeps ``n_lanes + 1`` lines.
        raw_ext: Extension that replaces the mask's in ``raw_file``.
    """

    max_lines: int | None = TUSIMPLE_MAX_LINES
    n_lanes: int | None = None
    raw_ext: str = ".jpg"

    def __post_init__(self) -> None:
        """Reject impossible counts."""
        if self.max_lines is not None and self.max_lines < 1:
            raise EvaluationError(f"max_lines must be at least 1, got {self.max_lines}")
        if self.n_lanes is not None and self.n_lanes < 1:
            raise EvaluationError(f"the lane count must be at least 1, got {self.n_lanes}")


@dataclass(frozen=True)
class FittedFrame:
    """One frame's fit as the export needs it.

    Attributes:
        name: Mask path relative to the segmentation folder (``clip/20.png``).
        lanes: Lines left to right (vehicle frame, metres).
        b: Road slope (rise over run).
        c: Vertical-curve term, 1/m (0 on the paper's linear road).
        fit_time_ms: Lane-fit time, milliseconds.
        seg_time_ms: Segmentation time, milliseconds (NaN when not measured).
    """

    name: str
    lanes: tuple[Lane, ...]
    b: float
    c: float
    fit_time_ms: float
    seg_time_ms: float = math.nan


def fitted_frame(row: Mapping[str, Any], name: str | None = None) -> FittedFrame:
    """Return a ``lanes.parquet`` row as a :class:`FittedFrame` (``name``: else the row's)."""
    lanes, slope = lanes_from_row(dict(row))
    colours, styles = row.get("colours"), row.get("styles")
    colours = list(colours) if colours is not None else ["unknown"] * len(lanes)
    styles = list(styles) if styles is not None else ["unknown"] * len(lanes)
    c, seg = row.get("c"), row.get("seg_time_ms")
    return FittedFrame(
        name=str(row["name"]) if name is None else name,
        lanes=tuple(
            dataclasses.replace(ln, colour=str(co), style=str(st))
            for ln, co, st in zip(lanes, colours, styles, strict=True)
        ),
        b=slope,
        c=float(c) if c is not None and math.isfinite(c) else 0.0,
        fit_time_ms=float(row.get("fit_time_ms") or 0.0),
        seg_time_ms=float(seg) if seg is not None else math.nan,
    )


def raw_file_of(name: str, raw_ext: str) -> str:
    """Return ``raw_file`` for a mask name: its relative path with the extension replaced."""
    ext = raw_ext if raw_ext.startswith(".") else f".{raw_ext}"
    return PurePosixPath(name).with_suffix(ext).as_posix()


def select_lines(lanes: Sequence[Lane], options: ExportOptions) -> list[int]:
    """Return the indices (left to right) of the lines to export.

    Args:
        lanes: Lines sorted left to right.
        options: Caps on the number of lines.
    """
    keep = list(range(len(lanes)))
    if options.n_lanes is not None and len(keep) > options.n_lanes + 1:
        width = options.n_lanes + 1
        support = [lanes[i].n_points for i in keep]
        centre = [abs(sum(lanes[i].offset_m for i in keep[s : s + width])) for s in keep]
        start = max(
            range(len(keep) - width + 1),
            key=lambda s: (sum(support[s : s + width]), -centre[s]),
        )
        keep = keep[start : start + width]
    if options.max_lines is not None and len(keep) > options.max_lines:
        nearest = sorted(keep, key=lambda i: abs(lanes[i].offset_m))[: options.max_lines]
        keep = sorted(nearest)
    return keep


def lane_columns(
    lanes: Sequence[Lane], b: float, c: float, camera: CameraModel, h_samples: Sequence[float]
) -> list[list[float]]:
    """Return one TuSimple x list per line (pixels at each row; ``-2`` where there is none)."""
    rows = np.asarray(h_samples, dtype=np.float64)
    cols = lanes_at_rows(list(lanes), b, camera, rows, vertical_curvature=c)
    inside = np.isfinite(cols) & (cols >= 0) & (cols <= camera.width - 1)
    out = np.where(inside, np.round(cols, 1), float(NO_POINT))
    return [[float(v) for v in row] for row in out]


def frame_record(
    frame: FittedFrame,
    camera: CameraModel,
    h_samples: Sequence[float],
    options: ExportOptions,
) -> TuSimpleRecord:
    """Return the TuSimple prediction record of one frame.

    Lines with no point on any row are dropped after the line selection.
    """
    chosen = [frame.lanes[i] for i in select_lines(frame.lanes, options)]
    columns = lane_columns(chosen, frame.b, frame.c, camera, h_samples)
    lanes, colors, styles = [], [], []
    for lane, xs in zip(chosen, columns, strict=True):
        if all(x == NO_POINT for x in xs):
            continue
        lanes.append(xs)
        colors.append(lane.colour)
        styles.append(lane.style)
    run_time = frame.fit_time_ms
    if math.isfinite(frame.seg_time_ms):
        run_time += frame.seg_time_ms
    return TuSimpleRecord(
        raw_file=raw_file_of(frame.name, options.raw_ext),
        lanes=lanes,
        h_samples=[float(h) for h in h_samples],
        run_time_ms=round(run_time, 3),
        colors=tuple(colors),
        styles=tuple(styles),
    )


def rows_by_raw_file(tasks: Sequence[TuSimpleRecord]) -> dict[str, list[float]]:
    """Return ``raw_file -> h_samples`` of a task or label file.

    Raises:
        EvaluationError: If a ``raw_file`` repeats with different rows.
    """
    out: dict[str, list[float]] = {}
    for task in tasks:
        if task.raw_file in out and out[task.raw_file] != task.h_samples:
            raise EvaluationError(f"task file lists {task.raw_file!r} twice with different rows")
        out[task.raw_file] = list(task.h_samples)
    return out


def export_records(
    frames: Sequence[FittedFrame],
    cameras: Sequence[CameraModel],
    options: ExportOptions,
    h_samples: Sequence[float] | None = None,
    tasks: dict[str, list[float]] | None = None,
) -> list[TuSimpleRecord]:
    """Return one record per frame, each sampled at its task's rows or at ``h_samples``.

    Args:
        frames: Fitted frames.
        cameras: The camera of each frame (sized to its mask).
        options: Line caps and ``raw_file`` extension.
        h_samples: Rows for every frame (used when ``tasks`` is None).
        tasks: ``raw_file -> h_samples`` (see :func:`rows_by_raw_file`).

    Raises:
        EvaluationError: If neither rows nor tasks are given, or a frame has no task entry.
    """
    if tasks is None and h_samples is None:
        raise EvaluationError("give h_samples or a task file")
    records: list[TuSimpleRecord] = []
    missing: list[str] = []
    for frame, cam in zip(frames, cameras, strict=True):
        raw = raw_file_of(frame.name, options.raw_ext)
        rows = tasks.get(raw) if tasks is not None else h_samples
        if rows is None:
            missing.append(raw)
            continue
        records.append(frame_record(frame, cam, rows, options))
    if missing:
        raise EvaluationError(
            f"{len(missing)} frame(s) have no entry in the task file (first: {missing[0]}); "
            "check --raw-ext and that the masks keep the task's relative paths"
        )
    return records
