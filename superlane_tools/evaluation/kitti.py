"""KITTI road benchmark metrics in the perspective image: ego-lane and road masks.

The KITTI road benchmark (Fritsch, Kuehnl and Geiger, ITSC 2013) scores a binary road or ego-lane
prediction against a ground-truth image whose colours code three states (``devkit_road``,
``helper.getGroundTruth``): magenta ``(255, 0, 255)`` is the positive area (the road, or for
``gt_*_lane_*`` the ego lane), red ``(255, 0, 0)`` the negative area, and black the area that is
not evaluated (``validArea`` = red channel set, ``roadArea`` = blue channel set). Counts are taken
over valid pixels only:

* ``precision = TP / (TP + FP)``, ``recall = TP / (TP + FN)``,
* ``F-measure = 2 P R / (P + R)`` (the benchmark's ``beta = 1``; with a binary prediction the
  benchmark's MaxF is this one value),
* ``FPR = FP / (FP + TN)``, ``FNR = FN / (TP + FN)``,
* ``IoU = TP / (TP + FP + FN)`` (not a KITTI column, but the figure the corridor paper reports).

The benchmark proper ranks methods in a bird's-eye view: see
:mod:`superlane_tools.evaluation.kitti_bev`; here everything is in the perspective image.
Everything here is pure: arrays in, numbers out; reading the PNGs is the caller's job.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from superlane_tools.camera.model import CameraModel
from superlane_tools.evaluation.errors import EvaluationError
from superlane_tools.lanes import Lane, columns_at_rows

BoolArray = NDArray[np.bool_]


class KittiGroundTruth(NamedTuple):
    """A decoded KITTI road or lane ground-truth image.

    Attributes:
        positive: ``(H, W)`` mask of the positive area (road, or the ego lane), magenta pixels.
        valid: ``(H, W)`` mask of the evaluated area (magenta or red pixels).
    """

    positive: BoolArray
    valid: BoolArray


class MaskScore(NamedTuple):
    """Pixel counts and rates of a binary prediction over the valid area.

    Attributes:
        tp: Predicted positive and positive, pixels.
        fp: Predicted positive and negative, pixels.
        fn: Predicted negative and positive, pixels.
        tn: Predicted negative and negative, pixels.
        precision: ``TP / (TP + FP)`` (0 when nothing is predicted).
        recall: ``TP / (TP + FN)`` (0 when there is no positive pixel).
        f_measure: ``2 P R / (P + R)`` (0 when both are 0).
        iou: ``TP / (TP + FP + FN)`` (0 when the union is empty).
        fpr: ``FP / (FP + TN)`` (0 when there is no negative pixel).
        fnr: ``FN / (TP + FN)`` (0 when there is no positive pixel).
    """

    tp: int
    fp: int
    fn: int
    tn: int
    precision: float
    recall: float
    f_measure: float
    iou: float
    fpr: float
    fnr: float


def decode_ground_truth(gt_rgb: NDArray[np.uint8]) -> KittiGroundTruth:
    """Decode a KITTI ground-truth image given in **RGB** channel order.

    Args:
        gt_rgb: ``(H, W, 3)`` uint8 image, RGB (flip an OpenCV BGR image first).

    Raises:
        EvaluationError: If the array is not an ``(H, W, 3)`` image.
    """
    arr = np.asarray(gt_rgb)
    if arr.ndim != 3 or arr.shape[2] != 3:
        raise EvaluationError(f"KITTI ground truth must be (H, W, 3) RGB, got shape {arr.shape}")
    return KittiGroundTruth(positive=arr[:, :, 2] > 0, valid=arr[:, :, 0] > 0)


def _ratio(num: int, den: int) -> float:
    return num / den if den > 0 else 0.0


def score_mask(prediction: BoolArray, gt: KittiGroundTruth) -> MaskScore:
    """Score a binary prediction against decoded ground truth, over the valid area only.

    Args:
        prediction: ``(H, W)`` boolean mask (True = predicted road or ego lane).
        gt: The decoded ground truth of the same size.

    Raises:
        EvaluationError: If the shapes differ.
    """
    pred = np.asarray(prediction, dtype=bool)
    if pred.shape != gt.positive.shape or gt.valid.shape != gt.positive.shape:
        raise EvaluationError(
            f"prediction shape {pred.shape} does not match ground truth {gt.positive.shape}"
        )
    pos = gt.positive & gt.valid
    neg = ~gt.positive & gt.valid
    tp = int(np.count_nonzero(pred & pos))
    fp = int(np.count_nonzero(pred & neg))
    fn = int(np.count_nonzero(~pred & pos))
    tn = int(np.count_nonzero(~pred & neg))
    precision = _ratio(tp, tp + fp)
    recall = _ratio(tp, tp + fn)
    f_measure = 2 * precision * recall / (precision + recall) if precision + recall > 0 else 0.0
    return MaskScore(
        tp=tp,
        fp=fp,
        fn=fn,
        tn=tn,
        precision=precision,
        recall=recall,
        f_measure=f_measure,
        iou=_ratio(tp, tp + fp + fn),
        fpr=_ratio(fp, fp + tn),
        fnr=_ratio(fn, tp + fn),
    )


def lane_area_mask(
    left_cols_px: NDArray[np.float64],
    right_cols_px: NDArray[np.float64],
    rows_px: NDArray[np.int64],
    shape: tuple[int, int],
) -> BoolArray:
    """Rasterise the area between two lane lines given as one column per image row.

    Each listed row is filled from ``ceil(min)`` to ``floor(max)`` of the two columns (clipped to
    the image); rows where either column is NaN (outside a line's fitted range) stay empty, so the
    area ends where the shorter line's support ends.

    Args:
        left_cols_px: Column of the left line on each row, pixels (NaN where undefined).
        right_cols_px: Column of the right line on each row, pixels (NaN where undefined).
        rows_px: Image rows the columns belong to (integers inside the image).
        shape: ``(height, width)`` of the mask.

    Raises:
        EvaluationError: If the three arrays differ in length.
    """
    left = np.asarray(left_cols_px, dtype=np.float64)
    right = np.asarray(right_cols_px, dtype=np.float64)
    rows = np.asarray(rows_px, dtype=np.int64)
    if not left.shape == right.shape == rows.shape:
        raise EvaluationError("left, right and rows must have the same length")
    height, width = shape
    out = np.zeros((height, width), dtype=bool)
    ok = np.isfinite(left) & np.isfinite(right) & (rows >= 0) & (rows < height)
    lo = np.clip(np.ceil(np.minimum(left, right)[ok]), 0, width).astype(np.int64)
    hi = np.clip(np.floor(np.maximum(left, right)[ok]), -1, width - 1).astype(np.int64)
    cols = np.arange(width)[None, :]
    out[rows[ok]] = (cols >= lo[:, None]) & (cols <= hi[:, None])
    return out


def ego_lane_mask(
    left: Lane,
    right: Lane,
    slope: float,
    camera: CameraModel,
    vertical_curvature: float = 0.0,
) -> BoolArray:
    """Rasterise the ego lane between two fitted lines in the camera image.

    Every image row is filled between the two lines' columns where both lines are inside their
    fitted ranges (:func:`superlane_tools.lanes.columns_at_rows`), so the area ends where the
    shorter line's support ends.

    Args:
        left: Ego-left line.
        right: Ego-right line.
        slope: Road slope ``b`` of the frame.
        camera: Camera of the image.
        vertical_curvature: Vertical-curve term ``c`` of the frame, 1/m.
    """
    rows = np.arange(camera.height, dtype=np.float64)
    cols_l = columns_at_rows(left, slope, camera, rows, vertical_curvature)
    cols_r = columns_at_rows(right, slope, camera, rows, vertical_curvature)
    return lane_area_mask(cols_l, cols_r, rows.astype(np.int64), (camera.height, camera.width))
