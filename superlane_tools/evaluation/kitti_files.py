"""KITTI road benchmark files: find frames, read ground truth, calibration and confidence maps.

Two layouts of ``KITTI_ROOT`` are recognised for a category such as ``um_lane``:

* the benchmark's ``training/gt_image_2/um_lane_000000.png`` with ``training/calib/um_000000.txt``
  (``KITTI_ROOT`` may also be the ``training`` folder itself);
* a flat folder ``gt_um_lane_000000.png`` with ``calib_um_000000.txt`` (``../shared/data``).

Predictions in ``PRED_DIR`` are the benchmark's perspective submission images:
``um_lane_000000.png`` (or ``um_000000.png``), read as the devkit reads result maps: 8-bit
grayscale (``cv2.imread(path, 0)``: a colour map becomes its luma, a 16-bit map its 8-bit
reduction), confidence = float32 ``value / 255``.
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from superlane_tools.camera.errors import CameraError
from superlane_tools.camera.kitti import read_kitti_calib
from superlane_tools.evaluation.errors import EvaluationError
from superlane_tools.evaluation.kitti import decode_ground_truth
from superlane_tools.evaluation.kitti_bev import (
    BevGrid,
    BevScore,
    SweepCounts,
    bev_lookup,
    devkit_confidence,
    ground_truth_to_bev,
    max_f_score,
    road_to_image_matrix,
)

CATEGORIES = ("um_lane", "um_road", "umm_road", "uu_road")
"""Benchmark categories (``um_lane`` is the ego-lane task)."""


@dataclass(frozen=True)
class KittiFrame:
    """Files of one benchmark frame.

    Attributes:
        frame_id: ``um_000000`` style id.
        gt: Ground-truth PNG.
        calib: Calibration text file.
    """

    frame_id: str
    gt: Path
    calib: Path


def find_frames(kitti_root: str | os.PathLike[str], category: str) -> list[KittiFrame]:
    """Return the ground-truth frames of ``category`` under ``kitti_root``, sorted by id.

    Raises:
        EvaluationError: If the category is unknown or no frame with its calibration is found.
    """
    if category not in CATEGORIES:
        raise EvaluationError(f"unknown category {category!r}; use one of {', '.join(CATEGORIES)}")
    root = Path(kitti_root)
    if not root.is_dir():
        raise EvaluationError(f"KITTI folder not found: {root}")
    road_type, _, task = category.partition("_")
    pattern = re.compile(rf"^(?:gt_)?{road_type}_{task}_(\d+)\.png$")
    frames: list[KittiFrame] = []
    missing_calib: list[str] = []
    for base in (root, root / "training"):
        for gt_dir in (base / "gt_image_2", base):
            if not gt_dir.is_dir():
                continue
            for path in sorted(gt_dir.iterdir()):
                match = pattern.match(path.name)
                if match is None:
                    continue
                frame_id = f"{road_type}_{match.group(1)}"
                calib = _find_calib(base, frame_id)
                if calib is None:
                    missing_calib.append(frame_id)
                    continue
                frames.append(KittiFrame(frame_id, path, calib))
        if frames:
            break
    if not frames:
        extra = f" ({len(missing_calib)} without calibration)" if missing_calib else ""
        raise EvaluationError(f"no {category} ground truth with calibration under {root}{extra}")
    return frames


def _find_calib(base: Path, frame_id: str) -> Path | None:
    for candidate in (base / "calib" / f"{frame_id}.txt", base / f"calib_{frame_id}.txt"):
        if candidate.is_file():
            return candidate
    return None


def read_png(path: Path, grayscale: bool = False) -> NDArray[np.generic]:
    """Read a PNG unchanged (bit depth and channels kept), or as 8-bit grayscale.

    Raises:
        EvaluationError: If it cannot be read.
    """
    import cv2  # late: heavy import

    image = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE if grayscale else cv2.IMREAD_UNCHANGED)
    if image is None:
        raise EvaluationError(f"cannot read image {path}")
    return np.asarray(image)


def find_prediction(pred_dir: Path, category: str, frame_id: str) -> Path | None:
    """Return the prediction file of a frame, or None."""
    number = frame_id.rsplit("_", 1)[1]
    road_type, _, task = category.partition("_")
    for name in (f"{road_type}_{task}_{number}.png", f"{frame_id}.png"):
        if (pred_dir / name).is_file():
            return pred_dir / name
    return None


@dataclass(frozen=True)
class KittiRun:
    """Outcome of :func:`evaluate_folder`.

    Attributes:
        score: The BEV score over the frames that had a prediction.
        missing: Frame ids without a prediction file (counted as all-negative predictions).
        frames: Frame ids scored.
    """

    score: BevScore
    missing: tuple[str, ...]
    frames: tuple[str, ...]


def evaluate_folder(
    pred_dir: str | os.PathLike[str],
    kitti_root: str | os.PathLike[str],
    category: str = "um_lane",
    grid: BevGrid | None = None,
) -> KittiRun:
    """Score perspective confidence maps in ``pred_dir`` in the BEV against ``kitti_root``.

    A frame without a prediction file is scored as an all-zero confidence map (the benchmark
    needs every frame) and listed in :attr:`KittiRun.missing`.

    Raises:
        EvaluationError: If no frame is found, a file is unreadable, sizes differ, or a
            calibration lacks ``Tr_cam_to_road``.
    """
    pdir = Path(pred_dir)
    if not pdir.is_dir():
        raise EvaluationError(f"prediction folder not found: {pdir}")
    frames = find_frames(kitti_root, category)
    counts = SweepCounts()
    missing: list[str] = []
    for frame in frames:
        gt_img = read_png(frame.gt)
        if gt_img.ndim != 3 or gt_img.shape[2] < 3:
            raise EvaluationError(f"{frame.gt}: not a colour ground-truth image")
        gt = decode_ground_truth(np.ascontiguousarray(gt_img[:, :, 2::-1]))  # BGR -> RGB
        height, width = gt.positive.shape
        pred_path = find_prediction(pdir, category, frame.frame_id)
        if pred_path is None:
            missing.append(frame.frame_id)
            conf = np.zeros((height, width), dtype=np.float32)
        else:
            conf = devkit_confidence(read_png(pred_path, grayscale=True))
            if conf.shape != (height, width):
                raise EvaluationError(
                    f"{pred_path}: size {conf.shape[1]}x{conf.shape[0]} differs from the "
                    f"ground truth's {width}x{height}"
                )
        try:
            calib = read_kitti_calib(frame.calib)
        except CameraError as err:
            raise EvaluationError(str(err)) from err
        if calib.cam_to_road is None or len(calib.projections) < 3:
            raise EvaluationError(f"{frame.calib}: needs P2 and Tr_cam_to_road")
        matrix = road_to_image_matrix(calib.projections[2], calib.r0_rect, calib.cam_to_road[:3])
        lookup = bev_lookup(matrix, (width, height), grid)
        bev_gt = ground_truth_to_bev(gt, lookup)
        counts.add(np.asarray(lookup.warp(conf, fill=0.0)), bev_gt)
    score = max_f_score(counts, len(frames))
    return KittiRun(score, tuple(missing), tuple(f.frame_id for f in frames))
