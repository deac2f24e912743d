"""Caltech Lanes true-positive rate (TPR), as Aly's evaluation script defines it.

Dataset: Aly, "Real time detection of lane markers in urban streets", IV 2008 -- four clips
(``cordova1``, ``cordova2``, ``washington1``, ``washington2``; the paper's Table 3 columns 1-4),
640 x 480 frames ``f00000.png``..., and per clip a ``labels.ccvl`` file: a MATLAB MAT-file whose
``ld.frames`` array holds, per frame, ``frame`` (the image name) and ``labels`` (``type``,
``subtype``, ``points``: the control points of a Bezier spline, pixels ``(x, y)``). Only labels of
type ``spline`` are lanes.

Matching rule (Aly's ``ccvGetLaneDetectionStats`` with ``ccvCheckMergeSplines``, the rule the
methods of Table 3 -- Aly 2008 and ML-CRF -- report TPR with):

* Both curves are sampled densely: a ground-truth Bezier spline at ``t = 0, 0.01, ..., 1``, a
  detection (a polyline from a ``.lines.txt`` file) at 101 points evenly spaced along its length.
* For every point of one curve, the distance to the nearest point of the other; the mean and the
  median of those distances in each direction; ``mean = min(mean1, mean2)``,
  ``median = min(median1, median2)``.
* A detection is correct when, for some ground-truth spline of its frame,
  ``mean <= 15 px`` **or** ``median <= 20 px``; otherwise it is a false detection.
* ``TPR = correct detections / ground-truth splines`` and ``FP/frame = false detections /
  frames``, summed over a clip. (As in the original, two detections on one lane both count as
  correct, so a detector that duplicates lines can exceed 1; :attr:`CaltechScore.duplicates`
  reports how many correct detections share a ground-truth spline.)
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from math import comb
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from superlane_tools.evaluation.culane import read_lines_file
from superlane_tools.evaluation.errors import EvaluationError

FloatArray = NDArray[np.float64]

MEAN_DIST_PX = 15.0
"""Mean-distance threshold of a match, pixels."""
MEDIAN_DIST_PX = 20.0
"""Median-distance threshold of a match, pixels."""
CLIPS = ("cordova1", "cordova2", "washington1", "washington2")
"""The four clips, in the order of the paper's Table 3 columns."""


def bezier_points(control: FloatArray, step: float = 0.01) -> FloatArray:
    """Return points of the Bezier curve with ``control`` points at ``t = 0, step, ..., 1``."""
    ctrl = np.asarray(control, dtype=np.float64).reshape(-1, 2)
    n = len(ctrl) - 1
    t = np.linspace(0.0, 1.0, round(1.0 / step) + 1)
    basis = np.stack([comb(n, k) * t**k * (1 - t) ** (n - k) for k in range(n + 1)], axis=1)
    out: FloatArray = basis @ ctrl
    return out


def polyline_points(points: FloatArray, n: int = 101) -> FloatArray:
    """Return ``n`` points evenly spaced along a polyline's length."""
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    seg = np.hypot(*np.diff(pts, axis=0).T)
    s = np.r_[0.0, np.cumsum(seg)]
    if s[-1] <= 0:
        return np.repeat(pts[:1], n, axis=0)
    target = np.linspace(0.0, s[-1], n)
    return np.stack([np.interp(target, s, pts[:, 0]), np.interp(target, s, pts[:, 1])], axis=1)


def curves_match(
    a: FloatArray,
    b: FloatArray,
    mean_px: float = MEAN_DIST_PX,
    median_px: float = MEDIAN_DIST_PX,
) -> bool:
    """Return whether two sampled curves match (``ccvCheckMergeSplines``)."""
    d = np.hypot(a[:, None, 0] - b[None, :, 0], a[:, None, 1] - b[None, :, 1])
    d1, d2 = d.min(axis=1), d.min(axis=0)
    mean = min(float(d1.mean()), float(d2.mean()))
    median = min(float(np.median(d1)), float(np.median(d2)))
    return mean <= mean_px or median <= median_px


@dataclass(frozen=True)
class CaltechScore:
    """TPR of one clip (or of all clips).

    Attributes:
        name: Clip name or ``all``.
        n_frames: Frames scored.
        n_truth: Ground-truth splines.
        n_detections: Detections.
        correct: Correct detections.
        false: False detections.
        duplicates: Correct detections beyond the first on the same ground-truth spline.
        tpr: ``correct / n_truth`` (0 without ground truth).
        fp_per_frame: ``false / n_frames``.
    """

    name: str
    n_frames: int
    n_truth: int
    n_detections: int
    correct: int
    false: int
    duplicates: int
    tpr: float
    fp_per_frame: float


def frame_matches(
    detections: Sequence[FloatArray], truth_splines: Sequence[FloatArray]
) -> tuple[int, int, int]:
    """Return ``(correct, false, duplicates)`` of one frame.

    Args:
        detections: Detected lanes as polylines ``(N, 2)``, pixels.
        truth_splines: Ground-truth Bezier control points ``(K, 2)``, pixels.
    """
    truths = [bezier_points(t) for t in truth_splines]
    correct = false = dup = 0
    hit = [False] * len(truths)
    for det in detections:
        pts = polyline_points(det)
        k = next((k for k, tr in enumerate(truths) if curves_match(pts, tr)), -1)
        if k < 0:
            false += 1
            continue
        correct += 1
        dup += int(hit[k])
        hit[k] = True
    return correct, false, dup


def score_frames(
    name: str, frames: Iterable[tuple[Sequence[FloatArray], Sequence[FloatArray]]]
) -> CaltechScore:
    """Sum :func:`frame_matches` over ``(detections, truth splines)`` frames."""
    n = truth = dets = ok = bad = dup = 0
    for detections, splines in frames:
        c, f, d = frame_matches(detections, splines)
        n += 1
        truth += len(splines)
        dets += len(detections)
        ok, bad, dup = ok + c, bad + f, dup + d
    return CaltechScore(
        name=name,
        n_frames=n,
        n_truth=truth,
        n_detections=dets,
        correct=ok,
        false=bad,
        duplicates=dup,
        tpr=ok / truth if truth else 0.0,
        fp_per_frame=bad / n if n else 0.0,
    )


def _as_list(value: Any) -> list[Any]:
    if value is None:
        return []
    if isinstance(value, list):
        return value
    if isinstance(value, np.ndarray) and value.dtype == object:
        return list(value.ravel())
    return [value]


def read_ccvl(path: str | os.PathLike[str]) -> list[tuple[str, list[FloatArray]]]:
    """Read a ``labels.ccvl`` MAT-file: ``(frame name, [spline control points])`` per frame.

    Raises:
        EvaluationError: If the file cannot be read or lacks ``ld.frames``.
    """
    from scipy.io import loadmat  # late: only this reader needs it
    from scipy.io.matlab import MatReadError

    file = Path(path)
    try:
        data = loadmat(str(file), simplify_cells=True)
    except (OSError, ValueError, TypeError, MatReadError) as err:
        raise EvaluationError(f"cannot read Caltech labels {file}: {err}") from err
    try:
        frames = _as_list(data["ld"]["frames"])
    except (KeyError, TypeError, IndexError) as err:
        raise EvaluationError(f"{file}: no ld.frames (not a labels.ccvl file)") from err
    out: list[tuple[str, list[FloatArray]]] = []
    for frame in frames:
        if not isinstance(frame, dict) or "frame" not in frame:
            raise EvaluationError(f"{file}: a frame has no 'frame' name")
        splines = []
        for label in _as_list(frame.get("labels")):
            if isinstance(label, dict) and str(label.get("type", "")) == "spline":
                pts = np.asarray(label.get("points"), dtype=np.float64).reshape(-1, 2)
                if len(pts) >= 2:
                    splines.append(pts)
        out.append((str(frame["frame"]), splines))
    return out


def evaluate_clip(
    pred_dir: str | os.PathLike[str], labels: str | os.PathLike[str], name: str
) -> tuple[CaltechScore, list[str]]:
    """Score the ``.lines.txt`` predictions of one clip against its ``labels.ccvl``.

    Predictions are ``pred_dir/<frame stem>.lines.txt``; a missing file is a frame without
    detections and is returned in the list of missing frames.

    Raises:
        EvaluationError: If a file is malformed.
    """
    pdir = Path(pred_dir)
    missing: list[str] = []
    pairs = []
    for frame, splines in read_ccvl(labels):
        pred = pdir / f"{Path(frame).stem}.lines.txt"
        if pred.is_file():
            detections = read_lines_file(pred)
        else:
            missing.append(frame)
            detections = []
        pairs.append((detections, splines))
    return score_frames(name, pairs), missing


def total(scores: Sequence[CaltechScore]) -> CaltechScore:
    """Return the counts of several clips summed (``all``)."""
    n = sum(s.n_frames for s in scores)
    truth = sum(s.n_truth for s in scores)
    ok = sum(s.correct for s in scores)
    bad = sum(s.false for s in scores)
    return CaltechScore(
        name="all",
        n_frames=n,
        n_truth=truth,
        n_detections=sum(s.n_detections for s in scores),
        correct=ok,
        false=bad,
        duplicates=sum(s.duplicates for s in scores),
        tpr=ok / truth if truth else 0.0,
        fp_per_frame=bad / n if n else 0.0,
    )
