"""The official TuSimple lane-benchmark metric (``LaneEval`` of TuSimple/tusimple-benchmark).

Reproduces ``evaluate/lane.py`` of the official benchmark, rule for rule:

* A predicted lane and a ground-truth (GT) lane are compared at the GT's ``h_samples`` rows.
  Missing points (negative x) become ``-100`` on both sides, so two missing points *match*.
* A point matches when ``|x_pred - x_gt| < 20 / cos(angle)`` pixels, where ``angle`` is the
  arctangent of the slope ``dx/dy`` of a least-squares line through the GT lane's valid points
  (0 when it has fewer than two).
* A lane's accuracy is matched points / all ``h_samples`` rows; each GT lane takes its best
  prediction. A GT lane is found when that accuracy is at least 0.85, else it is a false
  negative; ``FP = predictions - found``.
* With more than 4 GT lanes, one FN is forgiven and the worst lane accuracy is dropped; accuracy
  and FN are divided by ``max(min(4, n_gt), 1)``, FP by the number of predictions.
* A frame that took more than 200 ms, or has more than ``n_gt + 2`` predictions, scores
  ``(0, 0, 1)``.
* Totals are divided by the number of GT frames.

F1 follows common practice (LaneATT, CLRNet): ``tp = 1 - FP``, ``precision = tp / (tp + FP)``,
``recall = tp / (tp + FN)``, ``F1 = 2 P R / (P + R)``.

The one deliberate difference: ``run_time`` (milliseconds) is optional in predictions and
defaults to 0, so a label file can be scored against itself.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from superlane_tools.evaluation._files import read_text
from superlane_tools.evaluation.errors import EvaluationError

PIXEL_THRESH_PX = 20.0
"""Point match threshold in pixels for a vertical lane."""
POINT_ACC_THRESH = 0.85
"""Lane accuracy at or above which a GT lane counts as found."""
MAX_RUN_TIME_MS = 200.0
"""Frames slower than this score zero."""
MISSING_X = -100.0
"""Value the official code substitutes for missing points before comparing."""


class TuSimpleRecord(NamedTuple):
    """One line of a TuSimple JSON-lines file.

    Attributes:
        raw_file: Image path, the key that joins predictions and GT.
        lanes: Per lane, x in pixels at each ``h_samples`` row; negative = no point.
        h_samples: Image rows in pixels (may be empty in prediction files).
        run_time_ms: Processing time of the frame in milliseconds (0 if not given).
        colors: Per lane ``white``/``yellow``/``unknown`` (the ``color`` extension; empty when
            the file has none).
        styles: Per lane ``solid``/``dashed``/``double``/``unknown`` (the ``style`` extension).
    """

    raw_file: str
    lanes: list[list[float]]
    h_samples: list[float]
    run_time_ms: float = 0.0
    colors: tuple[str, ...] = ()
    styles: tuple[str, ...] = ()


class FrameScore(NamedTuple):
    """Per-frame result of :func:`bench`."""

    raw_file: str
    accuracy: float
    fp: float
    fn: float


@dataclass(frozen=True)
class TuSimpleScore:
    """TuSimple benchmark result over a set of frames.

    Attributes:
        accuracy: Mean per-frame point accuracy (0..1).
        fp: Mean per-frame false-positive rate (0..1).
        fn: Mean per-frame false-negative rate (0..1).
        f1: F1 from FP and FN (see the module docstring).
        n_frames: Number of GT frames.
    """

    accuracy: float
    fp: float
    fn: float
    f1: float
    n_frames: int

    def as_dict(self) -> dict[str, float | int]:
        """Return the score as a JSON-ready mapping."""
        return {
            "accuracy": self.accuracy,
            "fp": self.fp,
            "fn": self.fn,
            "f1": self.f1,
            "n_frames": self.n_frames,
        }


def f1_from_rates(fp: float, fn: float) -> float:
    """Return F1 from mean FP and FN rates, as LaneATT / CLRNet report it (0 when undefined)."""
    tp = 1.0 - fp
    if tp + fp <= 0.0 or tp + fn <= 0.0:
        return 0.0
    precision = tp / (tp + fp)
    recall = tp / (tp + fn)
    if precision + recall <= 0.0:
        return 0.0
    return 2.0 * precision * recall / (precision + recall)


def lane_angle(xs: Sequence[float], y_samples: Sequence[float]) -> float:
    """Return the GT lane's angle in radians: ``arctan`` of the fitted slope ``dx/dy``.

    Args:
        xs: Lane x in pixels per row; negative = no point.
        y_samples: Rows in pixels.
    """
    x = np.asarray(xs, dtype=np.float64)
    y = np.asarray(y_samples, dtype=np.float64)
    ok = x >= 0
    if int(ok.sum()) <= 1:
        return 0.0
    slope = np.polyfit(y[ok], x[ok], 1)[0]
    return float(np.arctan(slope))


def line_accuracy(pred: Sequence[float], gt: Sequence[float], thresh_px: float) -> float:
    """Return the fraction of rows where ``pred`` is within ``thresh_px`` of ``gt``."""
    p = np.asarray(pred, dtype=np.float64)
    g = np.asarray(gt, dtype=np.float64)
    p = np.where(p >= 0, p, MISSING_X)
    g = np.where(g >= 0, g, MISSING_X)
    return float(np.count_nonzero(np.abs(p - g) < thresh_px)) / g.size


def bench(
    pred_lanes: Sequence[Sequence[float]],
    gt_lanes: Sequence[Sequence[float]],
    y_samples: Sequence[float],
    running_time: float,
) -> tuple[float, float, float]:
    """Score one frame exactly like the official ``LaneEval.bench``.

    Args:
        pred_lanes: Predicted lanes, x in pixels per ``y_samples`` row (negative = none).
        gt_lanes: GT lanes in the same layout.
        y_samples: The GT's ``h_samples`` rows in pixels.
        running_time: Processing time of the frame in milliseconds.

    Returns:
        ``(accuracy, fp, fn)`` of the frame.

    Raises:
        EvaluationError: If a lane's length differs from ``y_samples``.
    """
    n_rows = len(y_samples)
    for kind, lanes in (("predicted", pred_lanes), ("ground-truth", gt_lanes)):
        for lane in lanes:
            if len(lane) != n_rows:
                raise EvaluationError(
                    f"format of lanes error: a {kind} lane has {len(lane)} points "
                    f"but there are {n_rows} h_samples"
                )
    if running_time > MAX_RUN_TIME_MS or len(gt_lanes) + 2 < len(pred_lanes):
        return 0.0, 0.0, 1.0
    n_gt, n_pred = len(gt_lanes), len(pred_lanes)
    thresholds = np.array(
        [PIXEL_THRESH_PX / math.cos(lane_angle(g, y_samples)) for g in gt_lanes],
        dtype=np.float64,
    )
    if n_gt and n_pred:
        gt = np.asarray(gt_lanes, dtype=np.float64).reshape(n_gt, n_rows)
        pred = np.asarray(pred_lanes, dtype=np.float64).reshape(n_pred, n_rows)
        gt = np.where(gt >= 0, gt, MISSING_X)
        pred = np.where(pred >= 0, pred, MISSING_X)
        close = np.abs(pred[None, :, :] - gt[:, None, :]) < thresholds[:, None, None]
        accs = np.count_nonzero(close, axis=2) / float(n_rows)  # (n_gt, n_pred)
        line_accs = accs.max(axis=1).tolist()
    else:
        line_accs = [0.0] * n_gt
    fn = float(sum(1 for acc in line_accs if acc < POINT_ACC_THRESH))
    matched = n_gt - fn
    fp = n_pred - matched
    if n_gt > 4 and fn > 0:
        fn -= 1
    total = sum(line_accs)
    if n_gt > 4:
        total -= min(line_accs)
    accuracy = total / max(min(4.0, n_gt), 1.0)
    fp_rate = fp / n_pred if n_pred > 0 else 0.0
    fn_rate = fn / max(min(float(n_gt), 4.0), 1.0)
    return float(accuracy), float(fp_rate), float(fn_rate)


def evaluate_frames(
    pred_records: Iterable[TuSimpleRecord], gt_records: Iterable[TuSimpleRecord]
) -> list[FrameScore]:
    """Score every GT frame against its prediction (joined on ``raw_file``).

    Returns:
        One score per prediction, in prediction order.

    Raises:
        EvaluationError: If a prediction has no GT frame, a GT frame has no prediction, a
            ``raw_file`` repeats, or lanes are malformed.
    """
    gts = _index(gt_records, "ground truth")
    preds = _index(pred_records, "predictions")
    unknown = [name for name in preds if name not in gts]
    if unknown:
        raise EvaluationError(
            f"{len(unknown)} predicted frame(s) are not in the ground truth (first: {unknown[0]})"
        )
    missing = [name for name in gts if name not in preds]
    if missing:
        raise EvaluationError(
            f"predictions are missing {len(missing)} of {len(gts)} ground-truth frame(s) "
            f"(first: {missing[0]})"
        )
    scores: list[FrameScore] = []
    for name, pred in preds.items():
        gt = gts[name]
        try:
            acc, fp, fn = bench(pred.lanes, gt.lanes, gt.h_samples, pred.run_time_ms)
        except EvaluationError as err:
            raise EvaluationError(f"{name}: {err}") from err
        scores.append(FrameScore(name, acc, fp, fn))
    return scores


def evaluate(
    pred_records: Iterable[TuSimpleRecord], gt_records: Iterable[TuSimpleRecord]
) -> TuSimpleScore:
    """Return the TuSimple accuracy, FP, FN and F1 of predictions against GT frames.

    Raises:
        EvaluationError: As :func:`evaluate_frames`, or if there are no GT frames.
    """
    frames = evaluate_frames(pred_records, gt_records)
    if not frames:
        raise EvaluationError("no ground-truth frames to evaluate")
    accuracy = fp = fn = 0.0
    for frame in frames:
        accuracy += frame.accuracy
        fp += frame.fp
        fn += frame.fn
    num = len(frames)
    fp_mean, fn_mean = fp / num, fn / num
    return TuSimpleScore(
        accuracy=accuracy / num,
        fp=fp_mean,
        fn=fn_mean,
        f1=f1_from_rates(fp_mean, fn_mean),
        n_frames=num,
    )


def _index(records: Iterable[TuSimpleRecord], what: str) -> dict[str, TuSimpleRecord]:
    out: dict[str, TuSimpleRecord] = {}
    for rec in records:
        if rec.raw_file in out:
            raise EvaluationError(f"{what}: raw_file {rec.raw_file!r} appears more than once")
        out[rec.raw_file] = rec
    return out


def parse_record(data: Any, require_h_samples: bool = True) -> TuSimpleRecord:
    """Validate one decoded JSON object and return it as a record.

    Raises:
        EvaluationError: If a field is missing or has the wrong type.
    """
    if not isinstance(data, dict):
        raise EvaluationError("expected a JSON object")
    raw_file = data.get("raw_file")
    if not isinstance(raw_file, str):
        raise EvaluationError("missing or non-string 'raw_file'")
    lanes = _number_lists(data.get("lanes"), "lanes")
    h_raw = data.get("h_samples")
    if h_raw is None and not require_h_samples:
        h_samples: list[float] = []
    else:
        h_samples = _numbers(h_raw, "h_samples")
    run_time = data.get("run_time", 0.0)
    if isinstance(run_time, bool) or not isinstance(run_time, int | float):
        raise EvaluationError("'run_time' must be a number of milliseconds")
    colors = _attribute(data.get("color"), "color", len(lanes))
    styles = _attribute(data.get("style"), "style", len(lanes))
    return TuSimpleRecord(raw_file, lanes, h_samples, float(run_time), colors, styles)


def _attribute(value: Any, field: str, n_lanes: int) -> tuple[str, ...]:
    if value is None:
        return ()
    if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
        raise EvaluationError(f"'{field}' must be a list of strings, one per lane")
    if len(value) != n_lanes:
        raise EvaluationError(f"'{field}' has {len(value)} entries for {n_lanes} lanes")
    return tuple(value)


def _numbers(value: Any, field: str) -> list[float]:
    if not isinstance(value, list) or not all(
        isinstance(v, int | float) and not isinstance(v, bool) for v in value
    ):
        raise EvaluationError(f"'{field}' must be a list of numbers")
    return [float(v) for v in value]


def _number_lists(value: Any, field: str) -> list[list[float]]:
    if not isinstance(value, list):
        raise EvaluationError(f"missing or non-list '{field}'")
    return [_numbers(lane, field) for lane in value]


def load_jsonl(
    path: str | os.PathLike[str], require_h_samples: bool = True
) -> list[TuSimpleRecord]:
    """Read a TuSimple JSON-lines file (one frame per line; blank lines are ignored).

    Args:
        path: The file.
        require_h_samples: Demand ``h_samples`` on every line (GT files); prediction files
            may omit it.

    Raises:
        EvaluationError: If the file cannot be read, or naming the first bad line.
    """
    file = Path(path)
    text = read_text(file)
    records: list[TuSimpleRecord] = []
    for number, line in enumerate(text.splitlines(), start=1):
        if not line.strip():
            continue
        try:
            data = json.loads(line)
        except json.JSONDecodeError as err:
            raise EvaluationError(f"{file}:{number}: not valid JSON: {err.msg}") from err
        try:
            records.append(parse_record(data, require_h_samples))
        except EvaluationError as err:
            raise EvaluationError(f"{file}:{number}: {err}") from err
    if not records:
        raise EvaluationError(f"{file}: no frames")
    return records


def format_record(record: TuSimpleRecord) -> str:
    """Return ``record`` as one TuSimple JSON line (without the newline).

    Whole-pixel x values are written as integers, like the official label files; ``color`` and
    ``style`` are written when the record has them.
    """
    lanes = [[_compact(x) for x in lane] for lane in record.lanes]
    data: dict[str, Any] = {
        "lanes": lanes,
        "h_samples": [_compact(h) for h in record.h_samples],
        "raw_file": record.raw_file,
        "run_time": _compact(record.run_time_ms),
    }
    if record.colors:
        data["color"] = list(record.colors)
    if record.styles:
        data["style"] = list(record.styles)
    return json.dumps(data, separators=(", ", ": "))


def _compact(value: float) -> int | float:
    return int(value) if float(value).is_integer() else float(value)
