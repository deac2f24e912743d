"""Lane fitting over a folder of class-id masks (exports: :mod:`.lanes_export`).

I/O edge of the lane stage: reads class-id PNGs (any folder depth, natural order) and a
``classes.yaml`` that maps hierarchy nodes to the integer ids in the PNGs, fits every frame with
:func:`superlane_tools.lanes.fit_frame`, and writes one Parquet row per frame with provenance.
"""

from __future__ import annotations

import csv
import math
import os
import re
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
import pyarrow as pa
from numpy.typing import NDArray

from superlane_tools.camera.model import CameraModel
from superlane_tools.commands.errors import PipelineError
from superlane_tools.errors import ConfigError
from superlane_tools.lanes import CODE_OF, FitParams, Lane, LaneFit, fit_frame
from superlane_tools.lanes.attributes import colour_codes_from_image
from superlane_tools.lanes.points import ClassLookup, LabelPoints, label_points
from superlane_tools.lanes.table import LANES_SCHEMA, fit_row
from superlane_tools.records import Skipped
from superlane_tools.reporting import (
    Provenance,
    input_identity,
    write_table,
)

Progress = Callable[[int, int], None]
"""Progress callback ``(done, total)``."""

SCHEMA = pa.schema([*LANES_SCHEMA, ("c", pa.float64()), ("seg_time_ms", pa.float64())])
"""Columns of ``lanes.parquet``: the lanes table plus the vertical-curve term ``c`` (1/m) and
the segmentation time of the mask (ms, NaN when unknown)."""


class ClassMap(NamedTuple):
    """Which class ids of the masks are lane markings and road.

    Attributes:
        lane_ids: Ids of lane-marking pixels (``lane_marking`` and its finer marking nodes).
        road_ids: Ids of road pixels for J1 (``road`` plus the lane markings on it).
        code_of_id: Lane-marking id -> level-4 attribute code (0 when unspecific).
    """

    lane_ids: tuple[int, ...]
    road_ids: tuple[int, ...]
    code_of_id: dict[int, int]


def parse_classes(data: Any, source: str = "<classes>") -> ClassMap:
    """Build a :class:`ClassMap` from a parsed ``classes.yaml`` mapping (node -> id or ids).

    Raises:
        ConfigError: If the mapping is malformed or names no lane-marking node.
    """
    if not isinstance(data, dict):
        raise ConfigError(f"{source}: expected a mapping of class nodes to integer ids")
    ids: dict[str, list[int]] = {}
    for node, value in data.items():
        values = value if isinstance(value, list) else [value]
        if not values or not all(isinstance(v, int) and not isinstance(v, bool) for v in values):
            raise ConfigError(f"{source}: {node!r} must map to an integer id or a list of ids")
        ids[str(node)] = [int(v) for v in values]
    code_of_id: dict[int, int] = {}
    for node, code in CODE_OF.items():
        for class_id in ids.get(node, []):
            code_of_id[class_id] = code
    if not code_of_id:
        raise ConfigError(
            f"{source}: no lane-marking node (lane_marking, dividing_white_solid, ...) is mapped"
        )
    lane_ids = tuple(sorted(code_of_id))
    road_ids = tuple(sorted(set(ids.get("road", [])) | set(lane_ids)))
    return ClassMap(lane_ids, road_ids, code_of_id)


def load_classes(path: str | os.PathLike[str]) -> ClassMap:
    """Read ``classes.yaml``.

    Raises:
        ConfigError: If the file is missing, not YAML, or malformed.
    """
    from superlane_tools.config_files import load_document

    return parse_classes(load_document(path, "class map", suffix=".yaml"), str(path))


def mask_points(mask: NDArray[Any], classes: ClassMap, seed: int = 0) -> LabelPoints:
    """Return the lane and road pixels of a class-id mask (see :func:`lanes.points.label_points`).

    Args:
        mask: ``(H, W)`` integer class ids.
        classes: Which ids are lane markings and road.
        seed: Seed of the deterministic subsampling of each kind.
    """
    lookup = ClassLookup.from_ids(classes.code_of_id, classes.road_ids)
    return label_points(mask, lookup, seed)


def natural_key(rel_path: str) -> tuple[tuple[int, int | str], ...]:
    """Sort key that orders digit runs by value (``clip/2.png`` before ``clip/10.png``)."""
    return tuple(
        (0, int(part)) if part.isdigit() else (1, part)
        for part in re.split(r"(\d+)", rel_path)
        if part
    )


def find_masks(seg_dir: str | os.PathLike[str]) -> list[Path]:
    """Return the PNG files under ``seg_dir`` (recursively), in natural order of relative path.

    Raises:
        PipelineError: If ``seg_dir`` is not a folder.
    """
    root = Path(seg_dir)
    if not root.is_dir():
        raise PipelineError(f"segmentation folder not found: {root}")
    return sorted(
        (p for p in root.rglob("*") if p.is_file() and p.suffix.lower() == ".png"),
        key=lambda p: natural_key(p.relative_to(root).as_posix()),
    )


def _read_mask(path: Path) -> NDArray[Any] | str:
    """Return the mask array, or why it cannot be used."""
    import cv2  # late: heavy import

    mask = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    if mask is None:
        return "unreadable PNG"
    if mask.ndim != 2:
        return f"not a single-channel class-id image (shape {mask.shape})"
    return mask


def _fit_row(
    name: str, width: int, height: int, fit: LaneFit, seg_time_ms: float
) -> dict[str, Any]:
    """Return one ``lanes.parquet`` row of this command (see :data:`SCHEMA`)."""
    return {**fit_row(name, width, height, fit), "c": fit.c, "seg_time_ms": seg_time_ms}


@dataclass(frozen=True)
class LanesFitResult:
    """Outcome of :func:`fit_masks`.

    Attributes:
        out: The written Parquet file.
        n_frames: Rows written (masks read).
        n_fitted: Frames with at least one lane.
        skipped: Masks that could not be used.
    """

    out: Path
    n_frames: int
    n_fitted: int
    skipped: tuple[Skipped, ...]


IMAGE_EXTS = (".jpg", ".jpeg", ".png")
"""Camera image extensions looked up beside a mask's relative path with ``images_dir``."""


def _read_image(images_dir: Path, rel: Path, size: tuple[int, int]) -> NDArray[np.uint8] | str:
    """Return the camera image for mask ``rel`` resized to the mask's ``size``, or why not."""
    import cv2  # late: heavy import

    for ext in IMAGE_EXTS:
        candidate = images_dir / rel.with_suffix(ext)
        if candidate.is_file():
            image = cv2.imread(str(candidate), cv2.IMREAD_COLOR)
            if image is None:
                return f"unreadable image {candidate.name}"
            if (image.shape[1], image.shape[0]) != size:
                image = cv2.resize(image, size, interpolation=cv2.INTER_AREA)
            return np.asarray(image, dtype=np.uint8)
    return f"no camera image for it under {images_dir}"


def fit_masks(
    seg_dir: str | os.PathLike[str],
    camera: CameraModel,
    out: str | os.PathLike[str],
    classes: ClassMap,
    params: FitParams | None = None,
    sequential: bool = False,
    command: str = "",
    progress: Progress | None = None,
    images_dir: str | os.PathLike[str] | None = None,
) -> LanesFitResult:
    """Fit every class-id PNG under ``seg_dir`` and write ``lanes.parquet``.

    Args:
        seg_dir: Folder of class-id PNG masks (searched recursively; names sorted).
        camera: Camera of the images; resized when a mask's size differs.
        out: Target Parquet path.
        classes: Class ids of lane markings and road.
        params: Fit parameters (paper defaults when None).
        sequential: Warm-start each frame from the previous frame's fit in the same folder (a
            clip); the first frame of each folder starts cold.
        command: Command line recorded in the provenance.
        progress: Called with ``(done, total)`` after each mask.
        images_dir: Folder of the camera images (same relative paths as the masks, any of the
            extensions in :data:`IMAGE_EXTS`): lane colour is read from the image along each
            line when the masks carry no level-4 marking classes.

    Raises:
        PipelineError: If there is no PNG, or no mask could be read.
    """
    p = params or FitParams()
    root = Path(seg_dir)
    paths = find_masks(root)
    if not paths:
        raise PipelineError(f"no PNG masks found under {root}")
    rows: list[dict[str, Any]] = []
    skipped: list[Skipped] = []
    previous: LaneFit | None = None
    clip = ""
    seg_times = read_segment_times(root)
    cameras: dict[tuple[int, int], CameraModel] = {}
    for done, path in enumerate(paths, start=1):
        name = path.relative_to(root).as_posix()
        if path.parent.as_posix() != clip:
            previous, clip = None, path.parent.as_posix()
        mask = _read_mask(path)
        if isinstance(mask, str):
            skipped.append(Skipped("mask", f"{name}: {mask}", 1))
        else:
            height, width = mask.shape
            cam = cameras.get((width, height))
            if cam is None:
                cam = (
                    camera
                    if camera.width == width and camera.height == height
                    else (camera.resized(width, height))
                )
                cameras[(width, height)] = cam
            pts = mask_points(mask, classes, p.seed)
            if images_dir is not None and not np.any(pts.codes > 0):
                image = _read_image(Path(images_dir), path.relative_to(root), (width, height))
                if isinstance(image, str):
                    skipped.append(Skipped("image", f"{name}: {image}", 1))
                else:
                    pts = pts._replace(codes=colour_codes_from_image(image, pts.lane_uv))
            init = previous if sequential and previous is not None and previous.ok else None
            fit = fit_frame(pts.lane_uv, pts.road_uv, cam, p, init=init, attributes=pts.codes)
            previous = fit
            seg_ms = seg_times.get(path.relative_to(root).with_suffix("").as_posix(), math.nan)
            rows.append(_fit_row(name, width, height, fit, seg_ms))
        if progress is not None:
            progress(done, len(paths))
    if not rows:
        raise PipelineError(f"none of the {len(paths)} masks under {root} could be read")
    table = pa.Table.from_pylist(rows, schema=SCHEMA)
    provenance = Provenance(
        command=command,
        inputs=(input_identity(root),),
        config={
            "fit_params": p.to_dict(),
            "camera": camera.to_dict(),
            "classes": classes._asdict(),
            "sequential": sequential,
        },
    )
    path_out = write_table(table, out, provenance)
    n_fitted = sum(1 for row in rows if row["offsets"])
    return LanesFitResult(path_out, len(rows), n_fitted, tuple(skipped))


def lanes_from_row(row: dict[str, Any]) -> tuple[list[Lane], float]:
    """Rebuild a frame's lanes and slope ``b`` from its ``lanes.parquet`` row."""
    lanes = [
        Lane(
            offset_m=float(o),
            a1=float(a1),
            a2=float(a2),
            range_min_m=float(lo),
            range_max_m=float(hi),
        )
        for o, a1, a2, lo, hi in zip(
            row["offsets"],
            row["lane_a1"],
            row["lane_a2"],
            row["range_min"],
            row["range_max"],
            strict=True,
        )
    ]
    b = row["b"]
    return lanes, float(b) if b is not None and math.isfinite(b) else 0.0


SEGMENT_TIMES_FILE = "segment_times.csv"
"""Per-frame segmentation times written by ``slt segment`` beside the masks (``name,seg_ms``)."""


def read_segment_times(seg_dir: Path) -> dict[str, float]:
    """Return ``name -> segmentation ms`` from ``seg_dir/segment_times.csv`` (empty if absent)."""
    path = seg_dir / SEGMENT_TIMES_FILE
    if not path.is_file():
        return {}
    out: dict[str, float] = {}
    with path.open(encoding="utf-8", newline="") as handle:
        for row in csv.DictReader(handle):
            try:
                out[row["name"]] = float(row["seg_ms"])
            except (KeyError, TypeError, ValueError):
                continue
    return out


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
