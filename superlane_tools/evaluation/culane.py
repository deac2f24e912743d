"""The CULane lane metric (F1 at IoU thresholds) and its ``.lines.txt`` format.

As the official evaluator (SCNN's ``evaluate``, run with ``-w 30 -t 0.5 -c 1640 -r 590``) and
its Python port in CLRNet/lanedet (``culane_metric.py``, ``official=True``) define it:

* A lane is a polyline of ``(x, y)`` pixel points; it is interpolated with a parametric spline
  through its points (``scipy.interpolate.splprep``, ``s = 0``, degree ``min(3, n - 1)``, 5
  samples per original segment) and drawn with 30 px wide ``cv2.line`` segments on a 590 x 1640
  canvas.
* IoU of every prediction / ground-truth pair = shared pixels / union pixels of their masks.
* Predictions and ground truth are matched one to one by the Hungarian algorithm on ``1 - IoU``
  (``scipy.optimize.linear_sum_assignment``); a matched pair is a true positive when its
  IoU is **strictly greater** than the threshold (CLRNet's ``>``; it differs from ``>=`` only on
  exact ties); ``FP = predictions - TP``, ``FN = ground truth - TP``.
* Counts are summed over the frames of a list (a scenario); ``precision = TP / (TP + FP)``,
  ``recall = TP / (TP + FN)``, ``F1 = 2 P R / (P + R)``. CLRNet also reports F1 at IoU 0.75
  and ``mF1``, the mean F1 over IoU ``0.50, 0.55, ..., 0.95``.

A ``.lines.txt`` file holds one lane per line: ``x1 y1 x2 y2 ...`` (pixels, spaces). Lanes with
fewer than two points are ignored, as the official reader does.
"""

from __future__ import annotations

import itertools
import os
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from superlane_tools.evaluation._files import read_text
from superlane_tools.evaluation.errors import EvaluationError

FloatArray = NDArray[np.float64]

CULANE_SIZE = (1640, 590)
"""Width and height of CULane images, pixels."""
LANE_WIDTH_PX = 30
"""Width the lanes are drawn with, pixels."""
MF1_THRESHOLDS = tuple(round(0.5 + 0.05 * k, 2) for k in range(10))
"""IoU thresholds of CLRNet's mF1: 0.50, 0.55, ..., 0.95."""
SUFFIX = ".lines.txt"


def parse_lines_text(text: str, source: str = "<lines>") -> list[FloatArray]:
    """Parse a ``.lines.txt`` text into ``(N, 2)`` point arrays (``x``, ``y`` pixels).

    Raises:
        EvaluationError: If a line has a non-number or an odd count of values.
    """
    lanes: list[FloatArray] = []
    for number, line in enumerate(text.splitlines(), start=1):
        if not line.strip():
            continue
        try:
            values = np.array([float(v) for v in line.split()], dtype=np.float64)
        except ValueError as err:
            raise EvaluationError(f"{source}:{number}: not a list of numbers") from err
        if values.size % 2:
            raise EvaluationError(f"{source}:{number}: odd number of coordinates")
        points = values.reshape(-1, 2)
        if len(points) >= 2:
            lanes.append(points)
    return lanes


def read_lines_file(path: str | os.PathLike[str]) -> list[FloatArray]:
    """Read a ``.lines.txt`` file (see :func:`parse_lines_text`).

    Raises:
        EvaluationError: If the file cannot be read or is malformed.
    """
    return parse_lines_text(read_text(path), str(path))


def format_lines(lanes: Iterable[FloatArray]) -> str:
    """Return lanes as ``.lines.txt`` text (``x y`` pairs, 3 decimals)."""
    rows = [" ".join(f"{x:.3f} {y:.3f}" for x, y in np.asarray(lane)) for lane in lanes]
    return "".join(f"{row}\n" for row in rows)


def interp_lane(points: FloatArray, n: int = 5) -> FloatArray:
    """Return the spline through ``points`` sampled ``n`` times per original segment."""
    from scipy.interpolate import splev, splprep  # late: only the evaluator needs it

    pts = np.asarray(points, dtype=np.float64)
    keep = np.r_[True, np.any(np.diff(pts, axis=0) != 0, axis=1)]
    pts = pts[keep]
    if len(pts) < 2:
        return pts
    tck, u = splprep([pts[:, 0], pts[:, 1]], s=0, k=min(3, len(pts) - 1))
    samples = np.linspace(0.0, 1.0, num=(len(u) - 1) * n + 1)
    return np.asarray(splev(samples, tck), dtype=np.float64).T


def lane_mask(
    points: FloatArray, size: tuple[int, int] = CULANE_SIZE, width: int = LANE_WIDTH_PX
) -> NDArray[np.bool_]:
    """Return the ``(H, W)`` mask of a polyline drawn ``width`` px wide."""
    import cv2  # late: heavy import

    img = np.zeros((size[1], size[0]), dtype=np.uint8)
    pts = np.asarray(points).astype(np.int32)
    for p1, p2 in itertools.pairwise(pts):
        cv2.line(img, (int(p1[0]), int(p1[1])), (int(p2[0]), int(p2[1])), 1, thickness=width)
    return img.astype(bool)


def cross_iou(
    pred: Sequence[FloatArray],
    gt: Sequence[FloatArray],
    size: tuple[int, int] = CULANE_SIZE,
    width: int = LANE_WIDTH_PX,
) -> FloatArray:
    """Return the ``(n_pred, n_gt)`` IoU of the lanes' drawn masks (after interpolation)."""
    pm = [lane_mask(interp_lane(p), size, width) for p in pred]
    gm = [lane_mask(interp_lane(g), size, width) for g in gt]
    out = np.zeros((len(pm), len(gm)))
    for i, a in enumerate(pm):
        for j, b in enumerate(gm):
            union = np.count_nonzero(a | b)
            out[i, j] = np.count_nonzero(a & b) / union if union else 0.0
    return out


def frame_counts(
    pred: Sequence[FloatArray],
    gt: Sequence[FloatArray],
    thresholds: Sequence[float] = (0.5,),
    size: tuple[int, int] = CULANE_SIZE,
    width: int = LANE_WIDTH_PX,
) -> list[tuple[int, int, int]]:
    """Return ``(tp, fp, fn)`` of one frame at each IoU threshold."""
    if not pred or not gt:
        return [(0, len(pred), len(gt)) for _ in thresholds]
    from scipy.optimize import linear_sum_assignment  # late: only the evaluator needs it

    ious = cross_iou(pred, gt, size, width)
    rows, cols = linear_sum_assignment(1.0 - ious)
    matched = ious[rows, cols]
    out = []
    for thr in thresholds:
        tp = int(np.count_nonzero(matched > thr))
        out.append((tp, len(pred) - tp, len(gt) - tp))
    return out


@dataclass(frozen=True)
class CulaneScore:
    """Summed counts and rates of a set of frames at one IoU threshold.

    Attributes:
        iou: The IoU threshold.
        tp: True positives.
        fp: False positives.
        fn: False negatives.
        precision: ``TP / (TP + FP)`` (0 when undefined).
        recall: ``TP / (TP + FN)`` (0 when undefined).
        f1: ``2 P R / (P + R)`` (0 when undefined).
    """

    iou: float
    tp: int
    fp: int
    fn: int
    precision: float
    recall: float
    f1: float


def score_counts(iou: float, tp: int, fp: int, fn: int) -> CulaneScore:
    """Return precision, recall and F1 of summed counts."""
    precision = tp / (tp + fp) if tp + fp else 0.0
    recall = tp / (tp + fn) if tp + fn else 0.0
    f1 = 2 * precision * recall / (precision + recall) if precision + recall else 0.0
    return CulaneScore(iou, tp, fp, fn, precision, recall, f1)


@dataclass(frozen=True)
class CulaneResult:
    """F1 of one frame list (scenario) at every threshold of :data:`MF1_THRESHOLDS`.

    Attributes:
        name: Scenario (list file stem) or ``all``.
        n_frames: Frames scored.
        scores: One score per threshold.
    """

    name: str
    n_frames: int
    scores: tuple[CulaneScore, ...]

    def at(self, iou: float) -> CulaneScore:
        """Return the score at threshold ``iou``.

        Raises:
            EvaluationError: If that threshold was not evaluated.
        """
        for score in self.scores:
            if abs(score.iou - iou) < 1e-9:
                return score
        raise EvaluationError(f"IoU {iou} was not evaluated")

    @property
    def mf1(self) -> float:
        """Mean F1 over the thresholds (CLRNet's mF1)."""
        return float(np.mean([s.f1 for s in self.scores]))


def evaluate_frames(
    pairs: Iterable[tuple[Sequence[FloatArray], Sequence[FloatArray]]],
    name: str = "all",
    thresholds: Sequence[float] = MF1_THRESHOLDS,
    size: tuple[int, int] = CULANE_SIZE,
    width: int = LANE_WIDTH_PX,
) -> CulaneResult:
    """Sum the counts of ``(pred lanes, gt lanes)`` frames at every threshold."""
    totals = np.zeros((len(thresholds), 3), dtype=np.int64)
    n = 0
    for pred, gt in pairs:
        totals += np.asarray(frame_counts(pred, gt, thresholds, size, width), dtype=np.int64)
        n += 1
    scores = tuple(
        score_counts(float(t), int(c[0]), int(c[1]), int(c[2]))
        for t, c in zip(thresholds, totals, strict=True)
    )
    return CulaneResult(name, n, scores)


def read_list(path: str | os.PathLike[str]) -> list[str]:
    """Read a CULane list file: image paths relative to the dataset root (first column).

    Raises:
        EvaluationError: If the file cannot be read or is empty.
    """
    text = read_text(path, "list")
    names = [line.split()[0].lstrip("/") for line in text.splitlines() if line.strip()]
    if not names:
        raise EvaluationError(f"{path}: empty list")
    return names


def lines_path(root: Path, image_rel: str) -> Path:
    """Return the ``.lines.txt`` of an image path relative to ``root``."""
    rel = Path(image_rel)
    return root / rel.with_name(rel.stem + SUFFIX) if rel.suffix != ".txt" else root / rel


@dataclass(frozen=True)
class CulaneRun:
    """Outcome of :func:`evaluate_folder`: one result per list, plus missing predictions."""

    results: tuple[CulaneResult, ...]
    missing: tuple[str, ...]


def evaluate_folder(
    pred_dir: str | os.PathLike[str],
    gt_root: str | os.PathLike[str],
    lists: Sequence[str | os.PathLike[str]] = (),
    thresholds: Sequence[float] = MF1_THRESHOLDS,
    size: tuple[int, int] = CULANE_SIZE,
) -> CulaneRun:
    """Score ``pred_dir`` against ``gt_root`` (``.lines.txt`` files at the same relative paths).

    Each list file is one scenario (CULane's ``list/test_split/test*_*.txt``); without lists all
    ``.lines.txt`` under ``gt_root`` form one set ``all``. A frame without a prediction file
    counts as a frame with no lanes and is listed in :attr:`CulaneRun.missing`.

    Raises:
        EvaluationError: If a folder is missing, a file is malformed, or no frame is found.
    """
    pred_root, root = Path(pred_dir), Path(gt_root)
    for folder in (pred_root, root):
        if not folder.is_dir():
            raise EvaluationError(f"folder not found: {folder}")
    if lists:
        sets = [(Path(lst).name.removesuffix(".txt"), read_list(lst)) for lst in lists]
    else:
        names = sorted(p.relative_to(root).as_posix() for p in root.rglob(f"*{SUFFIX}"))
        if not names:
            raise EvaluationError(f"no {SUFFIX} files under {root}")
        sets = [("all", names)]
    missing: set[str] = set()
    results = []
    for set_name, names in sets:
        pairs = []
        for rel in names:
            gt_file = lines_path(root, rel)
            if not gt_file.is_file():
                raise EvaluationError(f"no ground truth {gt_file}")
            pred_file = lines_path(pred_root, rel)
            if pred_file.is_file():
                pred = read_lines_file(pred_file)
            else:
                missing.add(rel)
                pred = []
            pairs.append((pred, read_lines_file(gt_file)))
        results.append(evaluate_frames(pairs, set_name, thresholds, size))
    return CulaneRun(tuple(results), tuple(sorted(missing)))
