"""Tests of the Hough ego-lane baseline on rendered, simulated and real frames."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from superlane_tools.camera.model import CameraModel
from superlane_tools.camera.profiles import load_camera
from superlane_tools.corridor import HoughParams, HoughTracker, detect_ego_lane


def _lines(
    cam: CameraModel,
    offsets_m: tuple[float, ...],
    *,
    dash_m: float = 0.0,
    gap_m: float = 0.0,
    curvature: float = 0.0,
    far_m: float = 60.0,
) -> np.ndarray:
    """Render lane lines (solid, or dashed ``dash_m`` / ``gap_m``) on a plain grey road."""
    img = np.full((cam.height, cam.width, 3), 80, dtype=np.uint8)
    thick = max(2, round(8 * cam.height / 720))
    period = dash_m + gap_m
    starts = np.arange(3.0, far_m, period) if dash_m > 0 else np.array([3.0])
    for y0 in offsets_m:
        for start in starts:
            stop = start + dash_m if dash_m > 0 else far_m
            x = np.linspace(start, min(stop, far_m), 60)
            pts = np.stack([x, y0 + 0.5 * curvature * x**2, np.zeros_like(x)], 1)
            uv, _ = cam.project(pts)
            cv2.polylines(img, [uv.round().astype(np.int32)], False, (230, 230, 230), thick)
    return img


def test_rendered_lane_width_is_recovered() -> None:
    cam = load_camera("sim_default")
    result = detect_ego_lane(_lines(cam, (1.75, -1.75)), cam)
    assert result.ok, result.reason
    assert abs(result.width_m - 3.5) < 0.25
    assert result.range_m > 30.0
    assert result.left_line is not None
    assert result.right_line is not None
    assert result.left_line.u0 < cam.intrinsics.cx < result.right_line.u0


@pytest.mark.parametrize("size", [(1280, 720), (640, 360)])
def test_dashed_lines_are_supported_beyond_the_time_gap_distance(size: tuple[int, int]) -> None:
    # US highway dashes (3 m line, 9 m gap): far dashes are a few pixels tall; the range follows
    # the edge support along the fitted line across the gaps, past 0.7 s at 30 m/s (21 m).
    cam = load_camera("sim_default").resized(*size)
    result = detect_ego_lane(_lines(cam, (1.85, -1.85), dash_m=3.0, gap_m=9.0), cam)
    assert result.ok, result.reason
    assert abs(result.width_m - 3.7) < 0.3
    assert 25.0 < result.range_m < 75.0  # dashes end at 60 m; far rows span metres


def test_range_stops_where_support_stops() -> None:
    cam = load_camera("sim_default").resized(640, 360)
    short = detect_ego_lane(_lines(cam, (1.85, -1.85), far_m=18.0), cam)
    assert short.ok, short.reason
    assert 14.0 < short.range_m < 21.0
    # A gap longer than max_gap_m ends the range at the near dashes.
    sparse = detect_ego_lane(_lines(cam, (1.85, -1.85), dash_m=3.0, gap_m=20.0), cam)
    assert sparse.ok, sparse.reason
    assert sparse.range_m < 10.0


def test_straight_line_model_is_short_on_a_tight_curve() -> None:
    cam = load_camera("sim_default").resized(640, 360)
    straight = detect_ego_lane(_lines(cam, (1.85, -1.85)), cam)
    curved = detect_ego_lane(_lines(cam, (1.85, -1.85), curvature=1 / 120), cam)
    assert straight.ok
    assert curved.ok, curved.reason
    assert curved.range_m < 0.7 * straight.range_m


def test_vehicle_edges_in_the_lane_are_not_boundaries() -> None:
    cam = load_camera("sim_default").resized(640, 360)
    img = _lines(cam, (1.85, -1.85))
    # A dark box standing 15 m ahead, 1.8 m wide: its side edges run nearly vertically.
    corners, _ = cam.project(np.array([[15.0, 0.9, 0.0], [15.0, -0.9, 1.4]]))
    (u0, v0), (u1, v1) = corners.round().astype(int)
    cv2.rectangle(img, (u0, v1), (u1, v0), (20, 20, 20), -1)
    result = detect_ego_lane(img, cam)
    assert result.ok, result.reason
    assert abs(result.width_m - 3.7) < 0.3


def test_blank_image_reports_why() -> None:
    cam = load_camera("sim_default")
    result = detect_ego_lane(np.full((720, 1280, 3), 80, np.uint8), cam)
    assert not result.ok
    assert result.reason
    assert np.isnan(result.width_m)


def test_one_sided_lane_is_not_ok() -> None:
    cam = load_camera("sim_default").resized(640, 360)
    result = detect_ego_lane(_lines(cam, (1.85,)), cam)
    assert not result.ok
    assert result.reason == "no right boundary"
    assert result.left_line is not None


def test_tracker_smooths_towards_the_new_frame() -> None:
    cam = load_camera("sim_default")
    tracker = HoughTracker(cam, alpha=0.5)
    first = tracker.update(_lines(cam, (1.75, -1.75)))
    second = tracker.update(_lines(cam, (2.0, -2.0)))
    raw = detect_ego_lane(_lines(cam, (2.0, -2.0)), cam)
    assert first.ok
    assert second.ok
    assert raw.ok
    assert first.width_m < second.width_m < raw.width_m


def test_simulated_straight_highway_is_available(tmp_path: Path) -> None:
    from superlane_tools.recording import open_recording
    from superlane_tools.recording.images import decode_frame
    from superlane_tools.simulation.drive import simulate_drive

    rec = tmp_path / "straight.mcap"
    simulate_drive("highway_straight", 1.0, 3, "mcap", 640, 360, False, rec)
    cam = load_camera("sim_default").resized(640, 360)
    with open_recording(rec) as recording:
        topic = next(t.topic for t in recording.topics() if "image" in t.topic)
        frames = [decode_frame(m) for m in recording.messages(topics=[topic])]
    results = [detect_ego_lane(f, cam) for f in frames]
    good = [r for r in results if r.ok and 3.2 < r.width_m < 4.2 and r.range_m > 21.0]
    assert len(good) >= 0.7 * len(frames), [(r.reason, r.width_m, r.range_m) for r in results]


def test_params_scale_with_the_image() -> None:
    cam = load_camera("sim_default")
    img = _lines(cam, (1.75, -1.75))
    half = cv2.resize(img, (640, 360), interpolation=cv2.INTER_AREA)
    full, small = detect_ego_lane(img, cam), detect_ego_lane(half, cam, HoughParams())
    assert full.ok
    assert small.ok
    assert abs(full.width_m - small.width_m) < 0.2


def test_real_tusimple_frames_have_a_plausible_ego_lane(realdata: Path) -> None:
    cam = load_camera("tusimple")
    folder = realdata / "tusimple" / "frames"
    widths = [detect_ego_lane(cv2.imread(str(folder / f"{i:04d}.png")), cam) for i in range(6)]
    plausible = [r for r in widths if r.ok and 2.5 <= r.width_m <= 4.5]
    assert len(plausible) >= 4, [(r.reason, r.width_m) for r in widths]
