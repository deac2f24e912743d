"""Tests of corridor width and length from masks and from lane offsets."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from superlane_tools.camera.profiles import load_camera
from superlane_tools.corridor import CorridorError, corridor_from_lanes, corridor_from_mask


def _corridor_mask(half_width_m: float, length_m: float, scale: float = 1.0) -> np.ndarray:
    cam = load_camera("sim_default")
    if scale != 1.0:
        cam = cam.resized(round(cam.width * scale), round(cam.height * scale))
    x = np.linspace(2.0, length_m, 300)
    left = np.stack([x, np.full_like(x, half_width_m), np.zeros_like(x)], 1)
    right = np.stack([x, np.full_like(x, -half_width_m), np.zeros_like(x)], 1)
    uv_l, _ = cam.project(left)
    uv_r, _ = cam.project(right)
    mask = np.zeros((cam.height, cam.width), dtype=np.uint8)
    cv2.fillPoly(mask, [np.concatenate([uv_l, uv_r[::-1]]).round().astype(np.int32)], 1)
    return mask


@pytest.mark.parametrize(("half", "length"), [(1.75, 40.0), (1.2, 25.0), (2.5, 60.0)])
def test_rendered_corridor_geometry(half: float, length: float) -> None:
    cam = load_camera("sim_default")
    geo = corridor_from_mask(_corridor_mask(half, length).astype(np.float32), cam)
    assert abs(geo.width_m - 2 * half) < 0.1
    assert 0.85 * length < geo.length_m <= 1.02 * length
    assert geo.n_rows > 50


def test_mask_at_another_resolution_uses_the_resized_camera() -> None:
    cam = load_camera("sim_default")
    geo = corridor_from_mask(_corridor_mask(1.75, 40.0, scale=0.5) > 0, cam)
    assert abs(geo.width_m - 3.5) < 0.15


def test_empty_and_bad_masks() -> None:
    cam = load_camera("sim_default")
    empty = corridor_from_mask(np.zeros((720, 1280)), cam)
    assert math.isnan(empty.width_m)
    assert math.isnan(empty.length_m)
    assert empty.n_rows == 0
    with pytest.raises(CorridorError):
        corridor_from_mask(np.zeros((2, 3, 4)), cam)


@given(
    st.floats(0.5, 4.0),
    st.floats(-4.0, -0.5),
    st.floats(1.0, 150.0),
)
def test_corridor_from_lanes(left: float, right: float, range_m: float) -> None:
    geo = corridor_from_lanes(left, right, range_m)
    assert geo.width_m == pytest.approx(left - right)
    assert geo.length_m == range_m
    assert math.isnan(corridor_from_lanes(None, right, range_m).width_m)


def _project_polygon(cam: object, pts_m: list[tuple[float, float]]) -> np.ndarray:
    xyz = np.array([[x, y, 0.0] for x, y in pts_m])
    uv, _ = cam.project(xyz)  # type: ignore[attr-defined]
    return np.asarray(uv.round().astype(np.int32))


def test_length_ignores_a_tapering_tip_and_stray_far_blobs() -> None:
    # A network mask that stays lane-wide to 30 m and then tapers to a point at 80 m, plus a
    # stray blob at 100 m: the corridor ends where it narrows below 80 % of its width, at
    # 30 + 0.2 * 50 = 40 m (the farthest mask row would say about 100 m).
    cam = load_camera("sim_default")
    mask = _corridor_mask(1.85, 30.0)
    tip = _project_polygon(cam, [(30.0, 1.85), (80.0, 0.0), (30.0, -1.85)])
    cv2.fillPoly(mask, [tip], 1)
    u, v = _project_polygon(cam, [(100.0, 0.0)])[0]
    mask[v - 1 : v + 2, u - 6 : u + 6] = 1
    geo = corridor_from_mask(mask > 0, cam)
    assert abs(geo.width_m - 3.7) < 0.1
    assert 37.0 < geo.length_m < 43.0


def test_length_bridges_short_holes_but_not_long_ones() -> None:
    cam = load_camera("sim_default")
    base = _corridor_mask(1.85, 40.0)
    holed = base.copy()
    v_hole = int(_project_polygon(cam, [(20.0, 0.0)])[0, 1])
    holed[v_hole : v_hole + 2] = 0  # two rows lost (a wiper, a tar seam): bridged
    assert corridor_from_mask(holed, cam).length_m == pytest.approx(
        corridor_from_mask(base, cam).length_m
    )
    cut = base.copy()
    cut[v_hole - 10 : v_hole + 2] = 0  # a long cut: the corridor ends before it
    assert corridor_from_mask(cut, cam).length_m < 21.0
