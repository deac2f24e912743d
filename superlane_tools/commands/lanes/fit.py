"""Lane fitting over a folder of class-id masks (exports: :mod:`.export`).

I/O edge of the lane stage: reads class-id PNGs (any folder depth, natural order) and a
``classes.yaml`` that maps hierarchy nodes to the integer ids in the PNGs, fits every frame with
:func:`superlane_tools.lanes.fit_frame`, and writes one Parquet row per frame with provenance.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
from numpy.typing import NDArray

from superlane_tools.camera.model import CameraModel
from superlane_tools.commands.errors import PipelineError
from superlane_tools.lanes import FitParams, LaneFit, fit_frame
from superlane_tools.lanes.attributes import colour_codes_from_image
from superlane_tools.lanes.class_map import ClassMap, mask_points
from superlane_tools.lanes.points import LabelPoints
from superlane_tools.lanes.table import fit_row
from superlane_tools.records import Skipped
from superlane_tools.reporting import (
    Provenance,
    input_identity,
    write_table,
)
from superlane_tools.reporting.layout import LANES_FIT_SCHEMA
from superlane_tools.scene.errors import SceneError
from superlane_tools.scene.label_folder import (
    find_masks,
    read_camera_image,
    read_mask,
    read_segment_times,
)

Progress = Callable[[int, int], None]
"""Progress callback ``(done, total)``."""


def _fit_row(
    name: str, width: int, height: int, fit: LaneFit, seg_time_ms: float
) -> dict[str, Any]:
    """Return one row of this command's table (see ``reporting.layout.LANES_FIT_SCHEMA``)."""
    return {**fit_row(name, width, height, fit), "seg_time_ms": seg_time_ms}


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
    try:
        paths = find_masks(root)
    except SceneError as err:
        raise PipelineError(str(err)) from err
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
        mask = read_mask(path)
        if isinstance(mask, str):
            skipped.append(Skipped("mask", f"{name}: {mask}", 1))
        else:
            height, width = mask.shape
            cam = cameras.get((width, height))
            if cam is None:
                cam = cameras[(width, height)] = _camera_at(camera, width, height)
            pts = _mask_lane_points(mask, classes, p.seed, images_dir, (root, path), skipped)
            init = previous if sequential and previous is not None and previous.ok else None
            fit = fit_frame(pts.lane_uv, pts.road_uv, cam, p, init=init, attributes=pts.codes)
            previous = fit
            seg_ms = seg_times.get(path.relative_to(root).with_suffix("").as_posix(), math.nan)
            rows.append(_fit_row(name, width, height, fit, seg_ms))
        if progress is not None:
            progress(done, len(paths))
    if not rows:
        raise PipelineError(f"none of the {len(paths)} masks under {root} could be read")
    config = {
        "fit_params": p.to_dict(),
        "camera": camera.to_dict(),
        "classes": classes._asdict(),
        "sequential": sequential,
    }
    provenance = Provenance(command=command, inputs=(input_identity(root),), config=config)
    path_out = write_table(pa.Table.from_pylist(rows, schema=LANES_FIT_SCHEMA), out, provenance)
    n_fitted = sum(1 for row in rows if row["offsets"])
    return LanesFitResult(path_out, len(rows), n_fitted, tuple(skipped))


def _camera_at(camera: CameraModel, width: int, height: int) -> CameraModel:
    """The camera for masks of ``width`` x ``height`` pixels (resized when they differ)."""
    if camera.width == width and camera.height == height:
        return camera
    return camera.resized(width, height)


def _mask_lane_points(
    mask: NDArray[Any],
    classes: ClassMap,
    seed: int,
    images_dir: str | os.PathLike[str] | None,
    where: tuple[Path, Path],
    skipped: list[Skipped],
) -> LabelPoints:
    """The mask's lane and road pixels; lane colour from the camera image when it has none.

    ``where`` is ``(root, path)`` of the mask; an unreadable image is added to ``skipped``.
    """
    root, path = where
    pts = mask_points(mask, classes, seed)
    if images_dir is not None and not np.any(pts.codes > 0):
        height, width = mask.shape
        image = read_camera_image(Path(images_dir), path.relative_to(root), (width, height))
        if isinstance(image, str):
            skipped.append(Skipped("image", f"{path.relative_to(root).as_posix()}: {image}", 1))
        else:
            pts = pts._replace(codes=colour_codes_from_image(image, pts.lane_uv))
    return pts
