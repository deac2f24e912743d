"""``slt eval kitti`` equals the official devkit_road's BEV numbers on the real ``um_000000``.

The expected numbers come from a slow, literal re-statement of what the devkit computes (written
here from its description, cell by cell, independent of ``evaluation/kitti_bev.py``):
``BirdsEyeView.computeBEVLookUpTable`` / ``transformImage2BEV`` (float32 cell centres from
``np.arange``, ``Tr33 = (P2 @ R0_rect @ inv(Tr_cam_to_road))[:, [0, 2, 3]]``, a cell is valid when
``1 <= u <= W`` and ``1 <= v <= H`` and takes pixel ``(uint(v) - 1, uint(u) - 1)``),
``helper.getGroundTruth`` (blue = road, red = valid), the result map read as 8-bit grayscale and
divided in float32, ``helper.evalExp`` (``np.histogram`` over ``[-inf, k/255..., inf]``) and
``helper.pxEval_maximizeFMeasure`` (MaxF, 11-point AP, rates at the MaxF threshold).
"""

from __future__ import annotations

import math
from pathlib import Path

import cv2
import numpy as np
import pytest

from superlane_tools.evaluation.kitti_files import evaluate_folder

pytestmark = pytest.mark.realdata


def _calib(path: Path) -> dict[str, list[float]]:
    out = {}
    for line in path.read_text().splitlines():
        key, sep, values = line.partition(":")
        if sep and values.strip():
            out[key.strip()] = [float(v) for v in values.split()]
    return out


def _tr33(calib: dict[str, list[float]]) -> np.ndarray:
    p2 = np.array(calib["P2"]).reshape(3, 4)
    r0 = np.eye(4)
    r0[:3, :3] = np.array(calib["R0_rect"]).reshape(3, 3)
    tr = np.eye(4)
    tr[:3, :] = np.array(calib["Tr_cam_to_road"]).reshape(3, 4)
    full = p2 @ r0 @ np.linalg.inv(tr)
    return full[:, [0, 2, 3]]


def _devkit_bev(image: np.ndarray, tr33: np.ndarray) -> np.ndarray:
    """Warp ``image`` to the 800 x 400 BEV one cell at a time, as the devkit's table does."""
    xs = np.arange(-10 + 0.05 / 2, 10, 0.05).astype(np.float32)
    zs = np.arange(46 - 0.05 / 2, 6, -0.05).astype(np.float32)
    assert (len(zs), len(xs)) == (800, 400)
    height, width = image.shape[:2]
    t = tr33.tolist()
    out = np.zeros((800, 400, *image.shape[2:]), image.dtype)
    for row, z32 in enumerate(zs):
        z = float(z32)
        for col, x32 in enumerate(xs):
            x = float(x32)
            hu = t[0][0] * x + t[0][1] * z + t[0][2]
            hv = t[1][0] * x + t[1][1] * z + t[1][2]
            hw = t[2][0] * x + t[2][1] * z + t[2][2]
            u, v = hu / hw, hv / hw
            if v >= 1 and u >= 1 and v <= height and u <= width:
                out[row, col] = image[int(v) - 1, int(u) - 1]
    return out


def _devkit_scores(gt_bgr: np.ndarray, prob_u8: np.ndarray, tr33: np.ndarray) -> dict[str, float]:
    gt_bev = _devkit_bev(gt_bgr, tr33)
    road, valid = gt_bev[:, :, 0] > 0, gt_bev[:, :, 2] > 0
    prob = np.clip(_devkit_bev(prob_u8, tr33).astype("f4") / 255, 0.0, 1.0)
    thresh = np.array(range(256)) / 255.0
    edges = np.concatenate(([-np.inf], thresh, [np.inf]))
    fn = np.cumsum(np.histogram(prob[road & valid], bins=edges)[0])[: len(thresh)]
    fp = np.cumsum(np.histogram(prob[~road & valid], bins=edges)[0][::-1])[::-1][1:]
    pos, neg = int((road & valid).sum()), int((~road & valid).sum())
    tp = pos - fn
    recall_all = tp / float(pos)
    precision_all = tp / (tp + fp + 1e-10)
    keep = ~((recall_all == 0) & (precision_all == 0))
    recall, precision = recall_all[keep], precision_all[keep]
    ap, levels = 0.0, 0
    for level in np.arange(0, 1.1, 0.1):
        at = precision[recall >= level]
        ap += max(at)
        levels += 1
    f = 2 * (precision * recall) / (precision + recall + 1e-10)
    best = int(f.argmax())
    t_p, f_p, f_n = float(tp[best]), float(fp[best]), float(fn[best])
    return {
        "max_f": float(f[best]),
        "average_precision": ap / levels,
        "precision": t_p / (t_p + f_p),
        "recall": t_p / pos,
        "fpr": f_p / neg,
        "fnr": f_n / pos,
        "threshold": float(thresh[best]),
    }


@pytest.mark.slow
def test_blurred_shifted_prediction_matches_the_devkit(realdata: Path, tmp_path: Path) -> None:
    root = realdata / "kitti_road"
    gt_bgr = cv2.imread(str(root / "gt_um_lane_000000.png"), cv2.IMREAD_UNCHANGED)
    ego = (gt_bgr[:, :, 0] > 0).astype(np.float32)
    # a soft, displaced, under-confident ego lane: blurred, 14 px right and 6 px down, x 0.9
    soft = cv2.GaussianBlur(ego, (0, 0), 9.0)
    soft = np.roll(np.roll(soft, 14, axis=1), 6, axis=0) * 0.9
    weak = np.roll(ego, 60, axis=1) * 0.35 + cv2.GaussianBlur(ego, (0, 0), 25.0) * 0.4
    tr33 = _tr33(_calib(root / "calib_um_000000.txt"))
    for name, conf in (("soft", soft), ("weak", weak)):
        pred = tmp_path / name
        pred.mkdir()
        prob = np.round(np.clip(conf, 0, 1) * 255).astype(np.uint8)
        cv2.imwrite(str(pred / "um_lane_000000.png"), prob)
        want = _devkit_scores(gt_bgr, cv2.imread(str(pred / "um_lane_000000.png"), 0), tr33)
        got = evaluate_folder(pred, root).score.as_dict()
        for key, value in want.items():
            # the bar is 0.1 point; the port is exact up to float32 rate rounding
            assert math.isclose(got[key], value, abs_tol=1e-6), (name, key, got[key], value)
        assert 0.2 < want["max_f"] < 0.98, want  # a real, imperfect prediction


def test_tiny_grid_hand_derived() -> None:
    """A hand-checkable sweep: 4 positive and 4 negative cells with 8-bit confidences."""
    from superlane_tools.evaluation.kitti import KittiGroundTruth
    from superlane_tools.evaluation.kitti_bev import devkit_confidence, evaluate_bev

    values = np.array([[255, 200, 128, 3, 250, 100, 2, 0]], np.uint8)
    positive = np.array([[1, 1, 1, 1, 0, 0, 0, 0]], bool)
    gt = KittiGroundTruth(positive=positive, valid=np.ones_like(positive))
    score = evaluate_bev([(devkit_confidence(values), gt)])
    # thresholds k/255: t in (100, 128]/255 keeps {255, 250, 200, 128}: TP 3, FP 1 -> P = R = 3/4
    # (F 0.75); t in (3, 100]/255 adds 100: P 3/5, R 3/4; t in (2, 3]/255 adds 3: P 4/6, R 1
    # -> F 0.8
    assert score.max_f == pytest.approx(0.8, abs=1e-9)
    assert (score.tp, score.fp, score.fn, score.tn) == (4, 2, 0, 2)
    assert score.threshold == pytest.approx(3 / 255)
    # AP: best precision at recall >= 0, .1, .2: 1 (t = 1: {255} only, R 1/4); at recall
    # >= .3 ... .7: 3/4 (t = 128/255); at .8, .9, 1: 4/6 (t = 3/255)
    assert score.average_precision == pytest.approx((3 * 1 + 5 * 3 / 4 + 3 * 4 / 6) / 11, abs=1e-9)
    # every 8-bit value k counts as positive at threshold k: float32 k/255 is never below the
    # float64 threshold k/255 (checked for all 256 values)
    k = np.arange(256)
    assert np.all(devkit_confidence(k.astype(np.uint8)).astype(np.float64) >= k / 255.0)
