"""KITTI road / ego-lane benchmark in the bird's-eye view (BEV), as the official devkit scores it.

Published definition: Fritsch, Kuehnl and Geiger, "A new performance measure and evaluation
benchmark for road detection algorithms", ITSC 2013; reference code ``devkit_road``
(``transform2BEV.py``, ``helper.evalExp``, ``helper.pxEval_maximizeFMeasure``).

**BEV transform.** A road point ``X = (x, 0, z, 1)`` (road frame: ``y = 0`` is the road surface,
``y`` down, ``x`` right, ``z`` forward, metres) maps to image-2 pixels as
``u ~ P2 @ R0_rect @ inv(Tr_cam_to_road) @ X`` (4x4 extensions of ``R0_rect`` and
``Tr_cam_to_road``), the devkit's ``Tr33`` with the ``y`` column dropped. The grid is 0.05 m
cells over ``x`` in ``[-10, 10)`` m (400 columns, left to right) and ``z`` in ``[6, 46)`` m
(800 rows, far to near: row 0 is ``z = 46 - 0.025``); the cell centres are the devkit's
``np.arange`` values stored as float32, as its look-up table does. A cell whose projection
``(u, v)`` lies in ``[1, W] x [1, H]`` takes pixel ``(floor(v) - 1, floor(u) - 1)`` (the devkit's
``uint32`` truncation of MATLAB-style 1-based coordinates); every other cell is 0 in every
channel, so it is outside the valid area.

**Scores.** The ground truth (decoded as in :mod:`superlane_tools.evaluation.kitti`: positive =
blue channel set, valid = red channel set) and a confidence map in ``[0, 1]`` are both warped.
Over all frames, for each of the 256 thresholds ``t = k / 255`` (float64), a valid cell is
predicted positive when its confidence is ``>= t``, the comparison the devkit's ``evalExp``
histogram makes (its confidences are float32 ``value / 255`` of an 8-bit map; see
:func:`devkit_confidence`); FN and FP are accumulated over frames. From the summed counts:
``recall = TP / P``, ``precision = TP / (TP + FP + 1e-10)``; thresholds where both are 0 are
dropped; ``F = 2 P R / (P + R + 1e-10)``, ``MaxF`` its maximum (first maximum); precision,
recall, FPR = ``FP / N``, FNR = ``FN / P`` are reported at the MaxF threshold; ``AP`` is the
devkit's PASCAL 11-point average (max precision at recall ``>= r`` for ``r`` in
``np.arange(0, 1.1, 0.1)``, levels with no such recall skipped).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from superlane_tools.evaluation.errors import EvaluationError
from superlane_tools.evaluation.kitti import KittiGroundTruth

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]

BEV_RES_M = 0.05
"""BEV cell size of the benchmark, metres."""
BEV_X_RANGE_M = (-10.0, 10.0)
"""Lateral extent of the BEV grid, metres (road frame ``x``, right positive)."""
BEV_Z_RANGE_M = (6.0, 46.0)
"""Forward extent of the BEV grid, metres (road frame ``z``)."""
N_THRESHOLDS = 256
"""Confidence thresholds ``k / 255``, ``k = 0..255``."""


@dataclass(frozen=True)
class BevGrid:
    """The benchmark's BEV grid.

    Attributes:
        res_m: Cell size, metres.
        x_range_m: ``[min, max)`` lateral extent, metres.
        z_range_m: ``[min, max)`` forward extent, metres.
    """

    res_m: float = BEV_RES_M
    x_range_m: tuple[float, float] = BEV_X_RANGE_M
    z_range_m: tuple[float, float] = BEV_Z_RANGE_M

    @property
    def shape(self) -> tuple[int, int]:
        """``(rows, columns)`` of a BEV image (800 x 400 for the benchmark grid)."""
        rows = round((self.z_range_m[1] - self.z_range_m[0]) / self.res_m)
        cols = round((self.x_range_m[1] - self.x_range_m[0]) / self.res_m)
        return rows, cols

    def cell_centres(self) -> tuple[FloatArray, FloatArray]:
        """Return ``(x, z)`` of every cell centre, metres, each ``(rows, cols)``.

        The values are the devkit's: ``np.arange`` from half a cell inside the limits, stored
        as float32 (its look-up table's type), returned as float64.
        """
        res = self.res_m
        x = np.arange(self.x_range_m[0] + res / 2, self.x_range_m[1], res)
        z = np.arange(self.z_range_m[1] - res / 2, self.z_range_m[0], -res)
        if (z.size, x.size) != self.shape:
            raise EvaluationError(f"BEV grid {self} does not divide into whole cells")
        xx, zz = np.meshgrid(x.astype(np.float32), z.astype(np.float32))
        return xx.astype(np.float64), zz.astype(np.float64)


def road_to_image_matrix(
    p2: FloatArray, r0_rect: FloatArray, cam_to_road: FloatArray
) -> FloatArray:
    """Return the 3x4 matrix ``P2 @ R0_rect @ inv(Tr_cam_to_road)`` (road point -> pixel).

    Args:
        p2: 3x4 projection matrix of camera 2, pixels.
        r0_rect: 3x3 rectifying rotation.
        cam_to_road: 3x4 or 4x4 camera -> road transform, metres.

    Raises:
        EvaluationError: If a matrix has the wrong shape.
    """
    p2 = np.asarray(p2, dtype=np.float64)
    r0 = np.asarray(r0_rect, dtype=np.float64)
    tr = np.asarray(cam_to_road, dtype=np.float64)
    if p2.shape != (3, 4) or r0.shape != (3, 3) or tr.shape not in ((3, 4), (4, 4)):
        raise EvaluationError(
            f"need P2 3x4, R0_rect 3x3, Tr_cam_to_road 3x4; got {p2.shape}, {r0.shape}, {tr.shape}"
        )
    r0_4 = np.eye(4)
    r0_4[:3, :3] = r0
    tr_4 = np.eye(4)
    tr_4[: tr.shape[0], :] = tr
    out: FloatArray = p2 @ r0_4 @ np.linalg.inv(tr_4)
    return out


def road_to_image(road_to_pixel: FloatArray, x_m: FloatArray, z_m: FloatArray) -> FloatArray:
    """Project road-surface points ``(x, 0, z)`` (metres) to ``(..., 2)`` pixels ``(u, v)``.

    Points behind the camera get NaN.
    """
    x = np.asarray(x_m, dtype=np.float64)
    z = np.asarray(z_m, dtype=np.float64)
    m = road_to_pixel[:, [0, 2, 3]]  # y = 0 on the road surface
    h = m @ np.vstack((x.ravel(), z.ravel(), np.ones(x.size)))
    with np.errstate(divide="ignore", invalid="ignore"):
        uv = np.where(h[2] > 0, h[:2] / h[2], np.nan)
    return uv.T.reshape(*x.shape, 2)


@dataclass(frozen=True)
class BevLookup:
    """Pixel lookup from every BEV cell into one image (the devkit's sampling).

    Attributes:
        rows: Image row of each cell (``(R, C)``, -1 outside the image).
        cols: Image column of each cell (-1 outside the image).
        inside: Cells whose pixel is inside the image.
    """

    rows: NDArray[np.intp]
    cols: NDArray[np.intp]
    inside: BoolArray

    def warp(self, image: NDArray[np.generic], fill: float = 0) -> NDArray[np.generic]:
        """Return ``image`` (``(H, W)`` or ``(H, W, C)``) resampled onto the BEV grid."""
        arr = np.asarray(image)
        out = np.full(self.rows.shape + arr.shape[2:], fill, dtype=arr.dtype)
        out[self.inside] = arr[self.rows[self.inside], self.cols[self.inside]]
        return out


def bev_lookup(
    road_to_pixel: FloatArray, image_size: tuple[int, int], grid: BevGrid | None = None
) -> BevLookup:
    """Return the devkit's lookup of ``grid`` into an image ``(width, height)``.

    A cell projecting to ``(u, v)`` with ``1 <= u <= W`` and ``1 <= v <= H`` takes pixel row
    ``floor(v) - 1`` and column ``floor(u) - 1``; other cells (and cells behind the camera)
    are outside the image.
    """
    g = grid or BevGrid()
    xx, zz = g.cell_centres()
    uv = road_to_image(road_to_pixel, xx, zz)
    width, height = image_size
    with np.errstate(invalid="ignore"):
        u, v = uv[..., 0], uv[..., 1]
        inside = (v >= 1) & (u >= 1) & (v <= height) & (u <= width)
        cols = np.floor(np.where(inside, u, 1.0)) - 1
        rows = np.floor(np.where(inside, v, 1.0)) - 1
    return BevLookup(
        rows=np.where(inside, rows, -1).astype(np.intp),
        cols=np.where(inside, cols, -1).astype(np.intp),
        inside=inside,
    )


def devkit_confidence(image: NDArray[np.generic]) -> NDArray[np.float32]:
    """Return the devkit's confidence of an 8-bit prediction map: float32 ``value / 255``.

    The devkit reads result maps as 8-bit grayscale (``cv2.imread(path, 0)``) and divides in
    float32; its thresholds are float64 ``k / 255``. Float32 ``k / 255`` is never below float64
    ``k / 255`` (all 256 values checked), so a cell of value ``k`` counts as positive at
    threshold ``k``; keeping float32 keeps every comparison the devkit's.

    Raises:
        EvaluationError: If the map is not 8-bit.
    """
    arr = np.asarray(image)
    if arr.dtype != np.uint8:
        raise EvaluationError(f"devkit confidence needs an 8-bit map, got {arr.dtype}")
    out: NDArray[np.float32] = np.clip(arr.astype(np.float32) / np.float32(255), 0.0, 1.0)
    return out


def ground_truth_to_bev(gt: KittiGroundTruth, lookup: BevLookup) -> KittiGroundTruth:
    """Warp decoded ground truth to the BEV; cells outside the image are not valid."""
    positive = np.asarray(lookup.warp(gt.positive, fill=False), dtype=bool)
    valid = np.asarray(lookup.warp(gt.valid, fill=False), dtype=bool) & lookup.inside
    return KittiGroundTruth(positive=positive, valid=valid)


class SweepCounts:
    """FN / FP per threshold, and positive / negative counts, accumulated over frames."""

    def __init__(self, n_thresholds: int = N_THRESHOLDS) -> None:
        """Start empty counts over ``n_thresholds`` thresholds ``k / (n - 1)``."""
        self.thresholds = np.arange(n_thresholds, dtype=np.float64) / (n_thresholds - 1)
        self.fn = np.zeros(n_thresholds, dtype=np.int64)
        self.fp = np.zeros(n_thresholds, dtype=np.int64)
        self.pos = 0
        self.neg = 0

    def add(self, confidence: FloatArray, gt: KittiGroundTruth) -> None:
        """Add one frame: ``confidence`` in ``[0, 1]``, same shape as the ground truth.

        Raises:
            EvaluationError: If the shapes differ.
        """
        conf = np.asarray(confidence, dtype=np.float64)
        if conf.shape != gt.positive.shape:
            raise EvaluationError(
                f"confidence shape {conf.shape} does not match ground truth {gt.positive.shape}"
            )
        pos = conf[gt.positive & gt.valid]
        neg = conf[~gt.positive & gt.valid]
        # predicted positive iff confidence >= t: FN(t) = #pos < t, FP(t) = #neg >= t
        self.fn += np.searchsorted(np.sort(pos), self.thresholds, side="left")
        self.fp += neg.size - np.searchsorted(np.sort(neg), self.thresholds, side="left")
        self.pos += int(pos.size)
        self.neg += int(neg.size)


@dataclass(frozen=True)
class BevScore:
    """The benchmark's figures over a set of frames (rates in ``[0, 1]``).

    Attributes:
        max_f: Maximum F-measure over the threshold sweep.
        average_precision: PASCAL 11-point average precision.
        precision: Precision at the MaxF threshold.
        recall: Recall at the MaxF threshold.
        fpr: False-positive rate ``FP / N`` at the MaxF threshold.
        fnr: False-negative rate ``FN / P`` at the MaxF threshold.
        threshold: The MaxF confidence threshold.
        tp: True-positive cells at that threshold.
        fp: False-positive cells.
        fn: False-negative cells.
        tn: True-negative cells.
        n_frames: Frames scored.
    """

    max_f: float
    average_precision: float
    precision: float
    recall: float
    fpr: float
    fnr: float
    threshold: float
    tp: int
    fp: int
    fn: int
    tn: int
    n_frames: int

    def as_dict(self) -> dict[str, float | int]:
        """Return the score as a JSON-ready mapping."""
        return {
            "max_f": self.max_f,
            "average_precision": self.average_precision,
            "precision": self.precision,
            "recall": self.recall,
            "fpr": self.fpr,
            "fnr": self.fnr,
            "threshold": self.threshold,
            "tp": self.tp,
            "fp": self.fp,
            "fn": self.fn,
            "tn": self.tn,
            "n_frames": self.n_frames,
        }


def max_f_score(counts: SweepCounts, n_frames: int) -> BevScore:
    """Return MaxF, AP and the rates at the MaxF threshold (``pxEval_maximizeFMeasure``).

    Raises:
        EvaluationError: If there is no positive cell at all.
    """
    if counts.pos == 0:
        raise EvaluationError("the ground truth has no positive cell in the valid area")
    tp = counts.pos - counts.fn
    tn = counts.neg - counts.fp
    recall = tp / float(counts.pos)
    precision = tp / (tp + counts.fp + 1e-10)
    keep = ~((recall == 0) & (precision == 0))
    if not np.any(keep):
        return BevScore(0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 0, 0, counts.pos, counts.neg, n_frames)
    idx = np.flatnonzero(keep)
    rec, prec = recall[idx], precision[idx]
    ap_sum, levels = 0.0, 0
    for level in np.arange(0.0, 1.1, 0.1):
        sel = rec >= level
        if np.any(sel):
            ap_sum += float(prec[sel].max())
            levels += 1
    f = 2.0 * prec * rec / (prec + rec + 1e-10)
    best = int(idx[int(np.argmax(f))])
    t_p, f_p, f_n, t_n = int(tp[best]), int(counts.fp[best]), int(counts.fn[best]), int(tn[best])
    return BevScore(
        max_f=float(f.max()),
        average_precision=ap_sum / levels if levels else 0.0,
        precision=t_p / (t_p + f_p) if t_p + f_p else 0.0,
        recall=t_p / counts.pos,
        fpr=f_p / counts.neg if counts.neg else 0.0,
        fnr=f_n / counts.pos,
        threshold=float(counts.thresholds[best]),
        tp=t_p,
        fp=f_p,
        fn=f_n,
        tn=t_n,
        n_frames=n_frames,
    )


def evaluate_bev(frames: Iterable[tuple[FloatArray, KittiGroundTruth]]) -> BevScore:
    """Score ``(confidence, ground truth)`` pairs already in the BEV (or any common grid).

    Raises:
        EvaluationError: If there is no frame, or as :meth:`SweepCounts.add`.
    """
    counts = SweepCounts()
    n = 0
    for conf, gt in frames:
        counts.add(conf, gt)
        n += 1
    if n == 0:
        raise EvaluationError("no frames to evaluate")
    return max_f_score(counts, n)
