"""Ego-lane and 3-lane modes of the TuSimple metric, and lane colour / style accuracy.

The SUPER paper scores its X-3000 set "similar to TuSimple" in two modes (Fig. 9): the ego lane
only, and 3 lanes (the ego lane and its left and right neighbours). Here a mode selects lines
from both the ground truth (GT) and the prediction of a frame, then the frame is scored with the
official :func:`superlane_tools.evaluation.tusimple.bench` rules:

* Each line's **base column** is its x extrapolated to the lowest ``h_samples`` row (a straight
  line through its lowest 5 points; a line with one point keeps that column).
* The **ego lines** are the line with the largest base column left of the image centre
  (``centre_px``, default half the image width) and the one with the smallest base column at or
  right of it. ``ego`` mode keeps those two (or the one that exists); ``3lane`` mode adds the next
  line outward on each side (up to 4 lines: 3 lanes).

**Colour / style accuracy** (the paper's 93.66 % and 92.58 %): over GT lines that carry a known
attribute (the ``color`` / ``style`` extension of the TuSimple JSON, not ``unknown``) and are
*found* by a prediction -- the prediction with the best point accuracy, at least 0.85, as
LaneEval finds lines -- the fraction whose predicted attribute equals the GT's. Style has two
classes as in the paper: ``double`` counts as ``solid``. Lines the detector missed are not
counted here (they are the FN of the detection score).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np

from superlane_tools.evaluation.errors import EvaluationError
from superlane_tools.evaluation.tusimple import (
    PIXEL_THRESH_PX,
    POINT_ACC_THRESH,
    FrameScore,
    TuSimpleRecord,
    TuSimpleScore,
    bench,
    f1_from_rates,
    lane_angle,
    line_accuracy,
)

MODES: tuple[str, ...] = ("all", "ego", "3lane")
"""Line selections: every line (official), the ego lines, the ego lane and its neighbours."""
UNKNOWN = "unknown"
STYLE_CLASSES = {"double": "solid"}
"""Style names folded into the paper's two classes (solid / dashed)."""


def base_column(xs: Sequence[float], h_samples: Sequence[float]) -> float:
    """Return the line's x extrapolated to the lowest row (NaN for a line with no point)."""
    x = np.asarray(xs, dtype=np.float64)
    y = np.asarray(h_samples, dtype=np.float64)
    ok = x >= 0
    if not np.any(ok):
        return math.nan
    xv, yv = x[ok], y[ok]
    order = np.argsort(yv)[-5:]
    if order.size < 2 or np.ptp(yv[order]) == 0:
        return float(xv[order[-1]])
    slope, intercept = np.polyfit(yv[order], xv[order], 1)
    return float(slope * y.max() + intercept)


def select_mode(
    lanes: Sequence[Sequence[float]], h_samples: Sequence[float], mode: str, centre_px: float
) -> list[int]:
    """Return the indices of the lines a mode keeps, in their original order."""
    if mode not in MODES:
        raise EvaluationError(f"unknown mode {mode!r}; use one of {', '.join(MODES)}")
    if mode == "all":
        return list(range(len(lanes)))
    bases = [(base_column(lane, h_samples), i) for i, lane in enumerate(lanes)]
    left = sorted((b, i) for b, i in bases if math.isfinite(b) and b < centre_px)
    right = sorted((b, i) for b, i in bases if math.isfinite(b) and b >= centre_px)
    per_side = 1 if mode == "ego" else 2
    keep = [i for _, i in left[::-1][:per_side]] + [i for _, i in right[:per_side]]
    return sorted(keep)


def _pick(record: TuSimpleRecord, keep: list[int]) -> TuSimpleRecord:
    return record._replace(
        lanes=[record.lanes[i] for i in keep],
        colors=tuple(record.colors[i] for i in keep) if record.colors else (),
        styles=tuple(record.styles[i] for i in keep) if record.styles else (),
    )


def mode_records(
    pred: TuSimpleRecord, gt: TuSimpleRecord, mode: str, centre_px: float
) -> tuple[TuSimpleRecord, TuSimpleRecord]:
    """Return the prediction and GT of one frame restricted to a mode's lines.

    The prediction is sampled at the GT's rows (as LaneEval requires).
    """
    rows = gt.h_samples
    return (
        _pick(pred, select_mode(pred.lanes, rows, mode, centre_px)),
        _pick(gt, select_mode(gt.lanes, rows, mode, centre_px)),
    )


def _join(
    preds: Iterable[TuSimpleRecord], gts: Iterable[TuSimpleRecord]
) -> list[tuple[TuSimpleRecord, TuSimpleRecord]]:
    gt_by = {g.raw_file: g for g in gts}
    pairs = []
    seen = set()
    for p in preds:
        if p.raw_file not in gt_by:
            raise EvaluationError(f"predicted frame {p.raw_file!r} is not in the ground truth")
        pairs.append((p, gt_by[p.raw_file]))
        seen.add(p.raw_file)
    missing = [name for name in gt_by if name not in seen]
    if missing:
        raise EvaluationError(
            f"predictions are missing {len(missing)} of {len(gt_by)} ground-truth frame(s) "
            f"(first: {missing[0]})"
        )
    if not pairs:
        raise EvaluationError("no ground-truth frames to evaluate")
    return pairs


def evaluate_mode(
    preds: Iterable[TuSimpleRecord],
    gts: Iterable[TuSimpleRecord],
    mode: str = "ego",
    centre_px: float = 640.0,
) -> TuSimpleScore:
    """Return the TuSimple score with both sides restricted to ``mode``'s lines.

    Raises:
        EvaluationError: If frames do not join, or lanes are malformed.
    """
    if mode not in MODES:
        raise EvaluationError(f"unknown mode {mode!r}; use one of {', '.join(MODES)}")
    frames: list[FrameScore] = []
    for pred, gt in _join(preds, gts):
        p, g = mode_records(pred, gt, mode, centre_px)
        try:
            acc, fp, fn = bench(p.lanes, g.lanes, g.h_samples, p.run_time_ms)
        except EvaluationError as err:
            raise EvaluationError(f"{gt.raw_file}: {err}") from err
        frames.append(FrameScore(gt.raw_file, acc, fp, fn))
    n = len(frames)
    fp_mean = sum(f.fp for f in frames) / n
    fn_mean = sum(f.fn for f in frames) / n
    return TuSimpleScore(
        accuracy=sum(f.accuracy for f in frames) / n,
        fp=fp_mean,
        fn=fn_mean,
        f1=f1_from_rates(fp_mean, fn_mean),
        n_frames=n,
    )


def found_pairs(pred: TuSimpleRecord, gt: TuSimpleRecord) -> list[tuple[int, int]]:
    """Return ``(gt index, pred index)`` of every GT line found by its best prediction."""
    pairs = []
    for j, g in enumerate(gt.lanes):
        if not pred.lanes:
            break
        thresh = PIXEL_THRESH_PX / math.cos(lane_angle(g, gt.h_samples))
        accs = [line_accuracy(p, g, thresh) for p in pred.lanes]
        best = int(np.argmax(accs))
        if accs[best] >= POINT_ACC_THRESH:
            pairs.append((j, best))
    return pairs


@dataclass(frozen=True)
class AttributeAccuracy:
    """Colour and style accuracy over found GT lines with a known attribute.

    Attributes:
        color: Fraction of found GT lines with a known colour whose predicted colour matches
            (NaN when there is none).
        style: The same for style (``double`` counted as ``solid``).
        n_color: GT lines counted for colour.
        n_style: GT lines counted for style.
        n_found: GT lines found by a prediction.
        n_gt: GT lines in all.
    """

    color: float
    style: float
    n_color: int
    n_style: int
    n_found: int
    n_gt: int

    def as_dict(self) -> dict[str, float | int]:
        """Return the accuracies as a JSON-ready mapping."""
        return {
            "color_accuracy": self.color,
            "style_accuracy": self.style,
            "n_color": self.n_color,
            "n_style": self.n_style,
            "n_found": self.n_found,
            "n_gt": self.n_gt,
        }


def attribute_accuracy(
    preds: Iterable[TuSimpleRecord],
    gts: Iterable[TuSimpleRecord],
    mode: str = "all",
    centre_px: float = 640.0,
) -> AttributeAccuracy:
    """Return colour and style accuracy of predictions against GT lines that carry them.

    Raises:
        EvaluationError: If frames do not join, or the GT has no ``color``/``style`` at all.
    """
    ok_c = ok_s = n_c = n_s = found = n_gt = 0
    any_attr = False
    for pred, gt in _join(preds, gts):
        p, g = mode_records(pred, gt, mode, centre_px)
        any_attr = any_attr or bool(g.colors or g.styles)
        n_gt += len(g.lanes)
        for j, i in found_pairs(p, g):
            found += 1
            if g.colors and g.colors[j] != UNKNOWN:
                n_c += 1
                ok_c += int(bool(p.colors) and p.colors[i] == g.colors[j])
            if g.styles and g.styles[j] != UNKNOWN:
                n_s += 1
                gs = STYLE_CLASSES.get(g.styles[j], g.styles[j])
                ps = STYLE_CLASSES.get(p.styles[i], p.styles[i]) if p.styles else UNKNOWN
                ok_s += int(ps == gs)
    if not any_attr:
        raise EvaluationError("the ground truth carries no 'color' or 'style' lists")
    return AttributeAccuracy(
        color=ok_c / n_c if n_c else math.nan,
        style=ok_s / n_s if n_s else math.nan,
        n_color=n_c,
        n_style=n_s,
        n_found=found,
        n_gt=n_gt,
    )
