"""Tests of the Hough ego-lane baseline on rendered and real frames."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from superlane_tools.camera.profiles import load_camera
from superlane_tools.corridor import HoughTracker, detect_ego_lane


def _render(lane_half_width_m: float) -> np.ndarray:
    cam = load_camera("sim_default")
    img = np.full((cam.height, cam.width, 3), 80, dtype=np.uint8)
    x = np.linspace(3.0, 60.0, 200)
    for y0 in (lane_half_width_m, -lane_half_width_m):
        pts = np.stack([x, np.full_like(x, y0), np.zeros_like(x)], 1)
        uv, _ = cam.project(pts)
        cv2.polylines(img, [uv.round().astype(np.int32)], False, (230, 230, 230), 8)
    return img


def test_rendered_lane_width_is_recovered() -> None:
    cam = load_camera("sim_default")
    result = detect_ego_lane(_render(1.75), cam)
    assert result.ok, result.reason
    assert abs(result.width_m - 3.5) < 0.25
    assert result.range_m > 30.0
    assert result.left_line is not None
    assert result.right_line is not None
    assert result.left_line.u0 < cam.intrinsics.cx < result.right_line.u0


def test_blank_image_reports_why() -> None:
    cam = load_camera("sim_default")
    result = detect_ego_lane(np.full((720, 1280, 3), 80, np.uint8), cam)
    assert not result.ok
    assert result.reason
    assert np.isnan(result.width_m)


def test_tracker_smooths_towards_the_new_frame() -> None:
    cam = load_camera("sim_default")
    tracker = HoughTracker(cam, alpha=0.5)
    first = tracker.update(_render(1.75))
    second = tracker.update(_render(2.0))
    raw = detect_ego_lane(_render(2.0), cam)
    assert first.ok
    assert second.ok
    assert raw.ok
    assert first.width_m < second.width_m < raw.width_m


def test_real_tusimple_frames_have_a_plausible_ego_lane(realdata: Path) -> None:
    cam = load_camera("tusimple")
    folder = realdata / "tusimple" / "frames"
    widths = [detect_ego_lane(cv2.imread(str(folder / f"{i:04d}.png")), cam) for i in range(6)]
    plausible = [r for r in widths if r.ok and 2.5 <= r.width_m <= 4.5]
    assert len(plausible) >= 4, [(r.reason, r.width_m) for r in widths]
