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
