"""The renderer's geometry is exact: true 3D lane lines land on lane-marking label pixels."""

from __future__ import annotations

from dataclasses import replace

import cv2
import numpy as np
import pytest

from superlane_tools.camera.model import CameraModel, Extrinsics, Intrinsics
from superlane_tools.simulation.render import render
from superlane_tools.simulation.render.examples import DEFAULT_CAMERA, example_scene
from superlane_tools.simulation.scene import FrameScene, LineStyle

MARKING_IDS = list(range(13, 20))

DISTORTED = CameraModel(
    Intrinsics(960, 540, 760.0, 760.0, 481.0, 268.0, (-0.12, 0.03, 0.001, -0.0005, 0.0)),
    Extrinsics(height_m=1.35, pitch_rad=0.04, roll_rad=0.01),
)


def line_points(scene: FrameScene, index: int, ahead_m: float) -> np.ndarray:
    """Return true 3D points (vehicle frame) on the centre of line ``index`` up to ``ahead_m``."""
    road = scene.road
    line = road.lines[index]
    s_ego = float(np.interp(0.0, road.x_m, road.s_m))
    s = np.arange(s_ego + 6.0, s_ego + ahead_m, 0.25)
    if line.style is LineStyle.DASHED:
        period = line.dash_m + line.gap_m
        m = np.mod(s - line.phase_m, period)
        s = s[(m > 0.2) & (m < line.dash_m - 0.2)]
    off = line.offset_at(s)
    hd = np.interp(s, road.s_m, road.heading_rad)
    x = np.interp(s, road.s_m, road.x_m) - np.sin(hd) * off
    y = np.interp(s, road.s_m, road.y_m) + np.cos(hd) * off
    z = np.interp(s, road.s_m, road.z_m)
    if line.style is LineStyle.DOUBLE:  # either stroke counts; test the left one
        sep = 0.5 * line.width_m + 0.075
        x, y = x - np.sin(hd) * sep, y + np.cos(hd) * sep
    return np.stack([x, y, z], axis=1)


def fraction_on_markings(scene: FrameScene, ahead_m: float = 90.0) -> float:
    frame = render(scene)
    marking = np.isin(frame.labels, MARKING_IDS).astype(np.uint8)
    near = cv2.dilate(marking, np.ones((5, 5), np.uint8)) > 0  # within 2 px
    hits, total = 0, 0
    for i in range(len(scene.road.lines)):
        uv, front = scene.camera.project(line_points(scene, i, ahead_m))
        # Points beyond a crest are hidden: keep those above every nearer point in the image,
        # except at the crest's silhouette itself, where rays graze the surface (sub-pixel).
        visible = uv[:, 1] <= np.minimum.accumulate(uv[:, 1]) + 0.5
        if np.any(np.diff(uv[front, 1]) > 0):
            visible &= uv[:, 1] > np.nanmin(uv[:, 1]) + 2.0
        keep = front & visible
        u, v = np.round(uv[keep, 0]).astype(int), np.round(uv[keep, 1]).astype(int)
        inside = (u >= 0) & (u < scene.camera.width) & (v >= 0) & (v < scene.camera.height)
        total += int(inside.sum())
        hits += int(near[v[inside], u[inside]].sum())
    assert total > 100
    return hits / total


@pytest.mark.parametrize("kind", ["straight", "curve", "hill"])
def test_true_lines_fall_on_marking_pixels(kind: str) -> None:
    scene = example_scene(kind, with_objects=False, s0_m=1234.5)
    assert fraction_on_markings(scene) >= 0.95


def test_true_lines_fall_on_marking_pixels_with_distortion_and_roll() -> None:
    scene = example_scene("curve", camera=DISTORTED, with_objects=False)
    assert fraction_on_markings(scene) >= 0.95


def test_crest_hides_the_road_behind_it() -> None:
    # A strong crest close ahead: rows just above the crest's image see no road beyond it.
    scene = example_scene("hill", with_objects=False)
    frame = render(scene)
    road = scene.road
    far = np.stack([road.x_m, road.y_m, road.z_m], axis=1)[road.x_m > 0]
    uv, _ = scene.camera.project(far)
    crest_v = float(np.min(uv[:, 1]))
    # The horizon of the road is the crest: nothing below the flat horizon is sky there...
    col = scene.camera.width // 2
    assert frame.labels[int(crest_v) + 3, col] != 1
    assert frame.labels[int(crest_v) - 3, col] in (1, 5, 8)


def test_corridor_lies_between_the_ego_lines_and_stops_at_its_length() -> None:
    scene = replace(example_scene("straight", with_objects=False), corridor_length_m=30.0)
    frame = render(scene)
    assert frame.corridor.sum() > 10000
    cam = scene.camera
    vv, uu = np.nonzero(frame.corridor)
    xy, ok = cam.ground_points(np.stack([uu, vv], axis=1).astype(float))
    assert ok.all()
    left = scene.road.lines[scene.ego_left_line].offset_m
    right = scene.road.lines[scene.ego_right_line].offset_m
    # One pixel of tolerance in metres at each pixel's distance.
    tol = xy[:, 0] / cam.intrinsics.fx * 1.5
    assert np.all(xy[:, 1] <= left + tol)
    assert np.all(xy[:, 1] >= right - tol)
    assert np.all(xy[:, 0] <= 30.0 + 0.1 + xy[:, 0] ** 2 / (cam.intrinsics.fy * 1.5))
    assert xy[:, 0].max() > 25.0
    assert np.all(np.isin(frame.labels[frame.corridor], [9, *MARKING_IDS]))


def test_default_camera_matches_the_bundled_profile() -> None:
    from superlane_tools.camera.profiles import load_camera

    profile = load_camera("sim_default")
    assert profile.intrinsics == DEFAULT_CAMERA.intrinsics
    assert profile.extrinsics == DEFAULT_CAMERA.extrinsics
