"""Tests of corridor width and length from masks and from lane offsets."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from superlane_tools.camera.profiles import load_camera
from superlane_tools.corridor import (
    CorridorError,
    CorridorParams,
    corridor_from_lanes,
    corridor_from_mask,
    width_distance,
)


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


def _widening_mask(cam: object, far_m: float) -> np.ndarray:
    """A corridor 3.0 m wide at 5 m widening linearly to 4.0 m at 15 m (and on), up to far_m."""
    xs = np.linspace(3.0, far_m, 120)
    half = 0.5 * np.clip(3.0 + 0.1 * (xs - 5.0), 2.8, 4.0)
    pts = [(x, h) for x, h in zip(xs, half, strict=True)]
    pts += [(x, -h) for x, h in zip(xs[::-1], half[::-1], strict=True)]
    mask = np.zeros((cam.height, cam.width), dtype=np.uint8)  # type: ignore[attr-defined]
    cv2.fillPoly(mask, [_project_polygon(cam, pts)], 1)
    return mask


@pytest.mark.parametrize(("at_m", "want_m"), [(10.0, 3.5), (7.0, 3.2), (13.0, 3.8)])
def test_mask_width_is_measured_at_the_configured_distance(at_m: float, want_m: float) -> None:
    cam = load_camera("sim_default")
    geo = corridor_from_mask(_widening_mask(cam, 40.0), cam, CorridorParams(width_at_m=at_m))
    assert geo.width_m == pytest.approx(want_m, abs=0.08)


def test_a_shorter_corridor_is_measured_at_its_end() -> None:
    cam = load_camera("sim_default")
    geo = corridor_from_mask(_widening_mask(cam, 8.0), cam)  # a leader 8 m ahead
    assert geo.length_m < 10.0
    want = 3.0 + 0.1 * (width_distance(10.0, geo.length_m) - 5.0)
    assert geo.width_m == pytest.approx(want, abs=0.1)


def test_lane_width_at_a_distance_from_curved_lines_and_a_shifted_origin() -> None:
    # Lines diverging with heading and curvature: 3.5 m apart at the lines' origin,
    # 3.5 + 0.02 x + 0.001 x^2 at x ahead of it.
    left, right = (1.75, 0.01, 1e-3), (-1.75, -0.01, 0.0)
    geo = corridor_from_lanes(left, right, 50.0, width_at_m=10.0)
    assert geo.width_m == pytest.approx(3.5 + 0.2 + 0.1)
    assert geo.length_m == 50.0
    # Lines fitted from a camera 2 m ahead of the vehicle origin: 10 m ahead of the origin is
    # 8 m ahead of the lines' origin, and the length counts from the vehicle origin too.
    geo = corridor_from_lanes(left, right, 50.0, width_at_m=10.0, x_origin_m=2.0)
    assert geo.width_m == pytest.approx(3.5 + 0.16 + 0.064)
    assert geo.length_m == 52.0
    # Lines seen only 6 m ahead: the width is taken where they end.
    assert corridor_from_lanes(left, right, 6.0).width_m == pytest.approx(3.5 + 0.12 + 0.036)
    assert math.isnan(corridor_from_lanes(left, None, 50.0).width_m)


def test_lengths_are_capped_at_the_measurable_range() -> None:
    """A mask reaching towards the horizon is capped where one row spans > 10 % of the distance."""
    from superlane_tools.corridor import measurable_range_m

    cam = load_camera("sim_default")  # 1280x720, f = 1000 px, 1.5 m high
    cap = measurable_range_m(cam)
    f, h = cam.intrinsics.fy, cam.extrinsics.height_m
    assert cap == pytest.approx(0.1 * f * h, rel=0.06)  # a row spans about x^2 / (f h)
    assert measurable_range_m(cam.resized(640, 360)) == pytest.approx(cap / 2, rel=0.03)
    far = corridor_from_mask(_corridor_mask(1.75, 600.0).astype(np.float32), cam)
    assert far.length_m == pytest.approx(cap)
    uncapped = corridor_from_mask(
        _corridor_mask(1.75, 600.0).astype(np.float32), cam, CorridorParams(max_row_step=0.0)
    )
    assert uncapped.length_m > 1.5 * cap
    near = corridor_from_mask(_corridor_mask(1.75, 40.0).astype(np.float32), cam)
    assert near.length_m < cap  # a measurable length is not touched
