"""KITTI bird's-eye-view benchmark: transform, MaxF/AP sweep, folder scoring and the CLI."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest
from typer.testing import CliRunner

from superlane_tools.camera.kitti import camera2_model, read_kitti_calib
from superlane_tools.cli.app import app
from superlane_tools.evaluation.errors import EvaluationError
from superlane_tools.evaluation.kitti import KittiGroundTruth, decode_ground_truth
from superlane_tools.evaluation.kitti_bev import (
    BevGrid,
    bev_lookup,
    evaluate_bev,
    ground_truth_to_bev,
    road_to_image,
    road_to_image_matrix,
)
from superlane_tools.evaluation.kitti_files import evaluate_folder, find_frames


def _gt(n_pos: int = 10, n_neg: int = 30, n_invalid: int = 5) -> KittiGroundTruth:
    n = n_pos + n_neg + n_invalid
    positive = np.zeros((1, n), bool)
    positive[0, :n_pos] = True
    valid = np.zeros((1, n), bool)
    valid[0, : n_pos + n_neg] = True
    return KittiGroundTruth(positive=positive, valid=valid)


def test_grid_is_the_benchmark_grid() -> None:
    grid = BevGrid()
    assert grid.shape == (800, 400)
    xx, zz = grid.cell_centres()
    assert xx[0, 0] == pytest.approx(-9.975)
    assert zz[0, 0] == pytest.approx(45.975)  # row 0 is the far end
    assert zz[-1, 0] == pytest.approx(6.025)


def test_perfect_prediction() -> None:
    gt = _gt()
    score = evaluate_bev([(gt.positive.astype(float), gt)])
    assert score.max_f == pytest.approx(1.0)
    assert (score.precision, score.recall, score.fpr, score.fnr) == (1.0, 1.0, 0.0, 0.0)
    assert score.average_precision == pytest.approx(1.0)


def test_empty_prediction_keeps_only_the_all_positive_threshold() -> None:
    gt = _gt()
    score = evaluate_bev([(np.zeros((1, 45)), gt)])
    # t = 0 predicts every valid cell: P = 10/40, R = 1; every t > 0 predicts nothing
    p = 10 / 40
    assert score.max_f == pytest.approx(2 * p / (p + 1), abs=1e-9)
    assert score.threshold == 0.0
    assert score.fpr == 1.0
    assert score.average_precision == pytest.approx(p)


def test_known_confusion_and_ap() -> None:
    gt = _gt()
    conf = np.zeros((1, 45))
    conf[0, :5] = 1.0  # 5 TP, 5 FN
    conf[0, 10:12] = 1.0  # 2 FP
    conf[0, 40:] = 1.0  # invalid cells never count
    score = evaluate_bev([(conf, gt)])
    p, r = 5 / 7, 0.5
    assert score.max_f == pytest.approx(2 * p * r / (p + r), abs=1e-9)
    assert (score.tp, score.fp, score.fn, score.tn) == (5, 2, 5, 28)
    assert score.fpr == pytest.approx(2 / 30)
    assert score.fnr == pytest.approx(0.5)
    # recall levels 0..0.5 reach precision 5/7 (t > 0); 0.6..1.0 only at t = 0 (precision 1/4)
    assert score.average_precision == pytest.approx((6 * p + 5 * 0.25) / 11)
    # a graded confidence: the 2 FP cells at 0.6 drop out above t = 0.6 -> precision 1
    conf[0, 10:12] = 0.6
    graded = evaluate_bev([(conf, gt)])
    assert graded.max_f == pytest.approx(2 / 3, abs=1e-9)
    assert graded.fp == 0
    assert graded.threshold > 0.6


def test_shifted_prediction_in_the_bev() -> None:
    positive = np.zeros((20, 400), bool)
    positive[:, 100:180] = True
    gt = KittiGroundTruth(positive=positive, valid=np.ones_like(positive))
    conf = np.zeros((20, 400))
    conf[:, 110:190] = 1.0
    score = evaluate_bev([(conf, gt)])
    assert score.precision == pytest.approx(70 / 80)
    assert score.recall == pytest.approx(70 / 80)
    assert score.max_f == pytest.approx(70 / 80, abs=1e-9)
    with pytest.raises(EvaluationError):
        evaluate_bev([])


def test_bev_transform_against_the_camera_model(realdata: Path) -> None:
    calib = read_kitti_calib(realdata / "kitti_road" / "calib_um_000000.txt")
    assert calib.cam_to_road is not None
    m = road_to_image_matrix(calib.projections[2], calib.r0_rect, calib.cam_to_road[:3])
    # explicit chain: road -> rectified camera (rigid inverse) -> P2
    rot, t = calib.cam_to_road[:3, :3], calib.cam_to_road[:3, 3]
    road = np.array([[-2.0, 0.0, 10.0], [0.0, 0.0, 20.0], [2.0, 0.0, 40.0]])
    cam = (road - t) @ rot  # R^T (X - t)
    r0 = np.eye(4)
    r0[:3, :3] = calib.r0_rect
    h = (calib.projections[2] @ r0 @ np.c_[cam, np.ones(3)].T).T
    uv = road_to_image(m, road[:, 0], road[:, 2])
    assert np.allclose(uv, h[:, :2] / h[:, 2:], atol=1e-9)
    # the package's camera-2 model (pitch/roll from the Velodyne calibration, documented 1.65 m
    # mount height) sees the same ground points within a few pixels; road x is right, vehicle y
    # is left, and the road frame's origin lies 0.28 m behind the camera
    model = camera2_model(calib)
    p2 = calib.projections[2]
    centre = rot @ -np.linalg.solve(p2[:, :3], p2[:, 3]) + t  # camera 2 in the road frame
    vehicle = np.c_[road[:, 2] - centre[2], -(road[:, 0] - centre[0]), np.zeros(3)]
    proj, front = model.project(vehicle)
    assert front.all()
    assert np.abs(proj - uv).max() < 6.0


def test_ground_truth_ego_lane_is_a_lane_wide_in_the_bev(realdata: Path) -> None:
    root = realdata / "kitti_road"
    calib = read_kitti_calib(root / "calib_um_000000.txt")
    assert calib.cam_to_road is not None
    gt_img = cv2.imread(str(root / "gt_um_lane_000000.png"))
    gt = decode_ground_truth(gt_img[:, :, ::-1])
    m = road_to_image_matrix(calib.projections[2], calib.r0_rect, calib.cam_to_road[:3])
    lookup = bev_lookup(m, (gt_img.shape[1], gt_img.shape[0]))
    bev = ground_truth_to_bev(gt, lookup)
    assert bev.positive.shape == (800, 400)
    # 10 m ahead (row of z = 10 m) the ego lane is 2.5-4.5 m wide (0.05 m cells)
    row = round((46.0 - 10.0) / 0.05)
    width_m = bev.positive[row].sum() * 0.05
    assert 2.5 < width_m < 4.5
    assert not bev.valid[:, :5].all()  # the image's footprint is narrower than 20 m near by


def test_folder_perfect_shifted_and_missing(realdata: Path, tmp_path: Path) -> None:
    root = realdata / "kitti_road"
    frames = find_frames(root, "um_lane")
    assert [f.frame_id for f in frames] == ["um_000000"]
    gt_img = cv2.imread(str(root / "gt_um_lane_000000.png"))
    ego = (gt_img[:, :, 0] > 0).astype(np.uint8) * 255  # blue channel (BGR) = positive
    perfect = tmp_path / "perfect"
    perfect.mkdir()
    cv2.imwrite(str(perfect / "um_lane_000000.png"), ego)
    run = evaluate_folder(perfect, root)
    assert run.score.max_f == pytest.approx(1.0, abs=1e-9)
    assert run.score.fpr == 0.0
    assert run.missing == ()
    shifted = tmp_path / "shifted"
    shifted.mkdir()
    cv2.imwrite(str(shifted / "um_lane_000000.png"), np.roll(ego, 40, axis=1))
    worse = evaluate_folder(shifted, root).score
    assert 0.3 < worse.max_f < 0.95
    assert worse.precision < 1.0
    empty = tmp_path / "empty"
    empty.mkdir()
    run = evaluate_folder(empty, root)
    assert run.missing == ("um_000000",)
    with pytest.raises(EvaluationError, match="unknown category"):
        evaluate_folder(empty, root, "xx_lane")


def test_cli_kitti_writes_a_record(realdata: Path, tmp_path: Path) -> None:
    root = realdata / "kitti_road"
    gt_img = cv2.imread(str(root / "gt_um_lane_000000.png"))
    pred = tmp_path / "pred"
    pred.mkdir()
    cv2.imwrite(str(pred / "um_lane_000000.png"), (gt_img[:, :, 0] > 0).astype(np.uint8) * 255)
    rec = tmp_path / "rec.json"
    res = CliRunner().invoke(
        app, ["eval", "kitti", str(pred), str(root), "--json", "--save", str(rec)]
    )
    assert res.exit_code == 0, res.output
    assert json.loads(res.stdout.splitlines()[-1])["max_f"] == pytest.approx(1.0)
    data = json.loads(rec.read_text())
    assert data["kind"] == "kitti"
    assert data["command"].startswith("slt eval kitti")
    assert len(data["predictions"]["sha256"]) == 64
    res = CliRunner().invoke(app, ["eval", "kitti", str(tmp_path / "nope"), str(root)])
    assert res.exit_code == 1
    assert "slt: error:" in res.output


def test_ego_lane_mask_lies_between_the_lines() -> None:
    from superlane_tools.camera import load_camera
    from superlane_tools.evaluation.kitti import ego_lane_mask
    from superlane_tools.lanes import Lane, columns_at_rows

    cam = load_camera("kitti")
    left, right = Lane(1.8, 0.0, 0.0, 5.0, 40.0), Lane(-1.8, 0.0, 0.0, 5.0, 40.0)
    mask = ego_lane_mask(left, right, 0.0, cam)
    rows = np.arange(cam.height, dtype=float)
    cl = columns_at_rows(left, 0.0, cam, rows)
    cr = columns_at_rows(right, 0.0, cam, rows)
    inside = np.isfinite(cl) & np.isfinite(cr)
    assert inside.any()
    assert not mask[~inside].any()  # nothing outside the lines' fitted range
    v = int(np.flatnonzero(inside)[-1])
    cols = np.flatnonzero(mask[v])
    assert cols[0] == pytest.approx(np.ceil(min(cl[v], cr[v])))
    assert cols[-1] == pytest.approx(np.floor(max(cl[v], cr[v])))
