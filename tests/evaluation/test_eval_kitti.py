"""Tests of the KITTI road / ego-lane mask metrics with hand-made masks."""

from __future__ import annotations

import numpy as np
import pytest

from superlane_tools.evaluation.errors import EvaluationError
from superlane_tools.evaluation.kitti import (
    KittiGroundTruth,
    decode_ground_truth,
    lane_area_mask,
    score_mask,
)


def _gt_image() -> np.ndarray:
    """A 4x6 RGB ground truth: left 2 columns invalid (black), ego lane magenta in rows 2-3."""
    img = np.zeros((4, 6, 3), dtype=np.uint8)
    img[:, 2:] = (255, 0, 0)  # red: evaluated, negative
    img[2:, 3:5] = (255, 0, 255)  # magenta: ego lane
    return img


def test_decode_ground_truth_colours() -> None:
    gt = decode_ground_truth(_gt_image())
    assert gt.valid.sum() == 16
    assert gt.positive.sum() == 4
    assert gt.positive[2, 3]
    assert not gt.positive[0, 3]
    assert not gt.valid[0, 0]
    with pytest.raises(EvaluationError, match="RGB"):
        decode_ground_truth(np.zeros((4, 6), dtype=np.uint8))


def test_score_counts_only_valid_pixels() -> None:
    gt = decode_ground_truth(_gt_image())
    pred = np.zeros((4, 6), dtype=bool)
    pred[2:, 3] = True  # 2 TP
    pred[1, 3] = True  # 1 FP
    pred[:, 0] = True  # invalid area: ignored
    s = score_mask(pred, gt)
    assert (s.tp, s.fp, s.fn, s.tn) == (2, 1, 2, 11)
    assert s.precision == pytest.approx(2 / 3)
    assert s.recall == pytest.approx(0.5)
    assert s.f_measure == pytest.approx(2 * (2 / 3) * 0.5 / (2 / 3 + 0.5))
    assert s.iou == pytest.approx(2 / 5)
    assert s.fpr == pytest.approx(1 / 12)
    assert s.fnr == pytest.approx(0.5)


def test_perfect_and_empty_predictions() -> None:
    gt = decode_ground_truth(_gt_image())
    perfect = score_mask(gt.positive, gt)
    assert (perfect.iou, perfect.f_measure, perfect.precision, perfect.recall) == (1, 1, 1, 1)
    empty = score_mask(np.zeros((4, 6), dtype=bool), gt)
    assert (empty.iou, empty.f_measure, empty.precision, empty.recall) == (0, 0, 0, 0)
    assert empty.fnr == 1.0
    blank = KittiGroundTruth(np.zeros((4, 6), bool), np.zeros((4, 6), bool))
    assert score_mask(np.ones((4, 6), bool), blank).iou == 0.0
    with pytest.raises(EvaluationError, match="shape"):
        score_mask(np.zeros((3, 6), dtype=bool), gt)


def test_lane_area_mask_fills_between_lines_and_stops_at_nan() -> None:
    rows = np.arange(5)
    left = np.array([np.nan, 1.2, 1.0, 0.5, -3.0])
    right = np.array([4.0, 3.0, 3.9, np.nan, 9.0])
    mask = lane_area_mask(left, right, rows, (5, 6))
    assert not mask[0].any()  # left line undefined
    assert mask[1].tolist() == [False, False, True, True, False, False]  # ceil(1.2)..floor(3.0)
    assert mask[2].tolist() == [False, True, True, True, False, False]
    assert not mask[3].any()  # right line undefined
    assert mask[4].all()  # clipped to the image
    swapped = lane_area_mask(right, left, rows, (5, 6))
    assert np.array_equal(mask, swapped)
    with pytest.raises(EvaluationError, match="same length"):
        lane_area_mask(left[:2], right, rows, (5, 6))
