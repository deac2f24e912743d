"""Property tests: projection round trips, IPM against ray casting, slope compensation."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from superlane_tools.camera import (
    CameraModel,
    Extrinsics,
    Intrinsics,
    LinearRoad,
    QuadraticRoad,
    compensate,
    compensate_linear,
    compensate_points,
    ground_to_image,
    image_to_ground,
    load_camera,
    ray_scale_numeric,
    road_height,
)

FAST = settings(max_examples=60, deadline=None)


@st.composite
def cameras(draw: st.DrawFn, distortion: bool = True, offset: bool = False) -> CameraModel:
    # Aspect and focal ranges keep the central 80 % of the image inside the region where every
    # drawn distortion is monotonic (normalised radius^2 <= 0.41).
    width = draw(st.integers(320, 1920))
    height = round(width * draw(st.floats(0.5, 0.8)))
    f = draw(st.floats(0.8, 1.5)) * width
    dist = (0.0, 0.0, 0.0, 0.0, 0.0)
    if distortion:
        dist = (
            draw(st.floats(-0.3, 0.1)),
            draw(st.floats(-0.05, 0.05)),
            draw(st.floats(-2e-3, 2e-3)),
            draw(st.floats(-2e-3, 2e-3)),
            draw(st.floats(-0.01, 0.01)),
        )
    intr = Intrinsics(
        width=width,
        height=height,
        fx=f,
        fy=f * draw(st.floats(0.95, 1.05)),
        cx=width / 2 + draw(st.floats(-20, 20)),
        cy=height / 2 + draw(st.floats(-20, 20)),
        dist=dist,
    )
    extr = Extrinsics(
        height_m=draw(st.floats(0.8, 3.5)),
        pitch_rad=draw(st.floats(0.0, 0.2)),
        roll_rad=draw(st.floats(-0.03, 0.03)),
        yaw_rad=draw(st.floats(-0.05, 0.05)),
        x_m=draw(st.floats(-2.0, 2.0)) if offset else 0.0,
        y_m=draw(st.floats(-1.0, 1.0)) if offset else 0.0,
    )
    return CameraModel(intr, extr)


def _pixels(cam: CameraModel, seed: int, n: int = 200, lower: float = 0.0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    # keep to the central 80 % of the image, where every drawn distortion is monotonic
    u = rng.uniform(0.1, 0.9, n) * cam.width
    v = rng.uniform(max(lower, 0.1), 0.9, n) * cam.height
    return np.stack([u, v], axis=1)


def _below_horizon(cam: CameraModel, seed: int) -> np.ndarray:
    uv = _pixels(cam, seed, n=400, lower=0.55)
    _, valid = cam.ground_points(uv)
    return uv[valid]


@FAST
@given(cam=cameras(), seed=st.integers(0, 2**31), depth=st.floats(2.0, 200.0))
def test_back_project_then_project_returns_the_pixel(
    cam: CameraModel, seed: int, depth: float
) -> None:
    uv = _pixels(cam, seed)
    points = cam.extrinsics.position + depth * cam.rays(uv)
    uv2, front = cam.project(points)
    assert front.all()
    np.testing.assert_allclose(uv2, uv, atol=1e-6)


@FAST
@given(cam=cameras(offset=True), seed=st.integers(0, 2**31))
def test_image_to_ground_matches_ray_casting_onto_the_road(cam: CameraModel, seed: int) -> None:
    uv = _below_horizon(cam, seed)
    x, y, valid = image_to_ground(cam, uv)
    assert valid.all()
    dirs = cam.rays(uv)
    t = cam.extrinsics.height_m / -dirs[:, 2]
    pos = cam.extrinsics.position
    np.testing.assert_allclose(x, pos[0] + t * dirs[:, 0], rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(y, pos[1] + t * dirs[:, 1], rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(ground_to_image(cam, x, y), uv, atol=1e-6)


@FAST
@given(cam=cameras(offset=True), seed=st.integers(0, 2**31), z=st.floats(-0.5, 1.0))
def test_ground_to_image_then_rays_point_back_at_the_point(
    cam: CameraModel, seed: int, z: float
) -> None:
    rng = np.random.default_rng(seed)
    x = rng.uniform(5.0, 60.0, 100) + cam.extrinsics.x_m
    y = rng.uniform(-0.2, 0.2, 100) * (x - cam.extrinsics.x_m) + cam.extrinsics.y_m
    uv = ground_to_image(cam, x, y, z)
    inside = (uv[:, 0] > 0.1 * cam.width) & (uv[:, 0] < 0.9 * cam.width)
    inside &= (uv[:, 1] > 0.1 * cam.height) & (uv[:, 1] < 0.9 * cam.height)
    rel = np.stack([x, y, np.full_like(x, z)], axis=1) - cam.extrinsics.position
    want = rel / np.linalg.norm(rel, axis=1, keepdims=True)
    np.testing.assert_allclose(cam.rays(uv[inside]), want[inside], atol=1e-9)


def _cast_onto_road(cam: CameraModel, uv: np.ndarray, f_road) -> np.ndarray:  # type: ignore[no-untyped-def]
    """Ray-cast pixels onto the road z = f_road(x - x_cam): march to the first crossing, bisect."""
    dirs = cam.rays(uv)
    pos = cam.extrinsics.position

    def below(t: np.ndarray) -> np.ndarray:
        p = pos + t[:, None] * dirs
        return p[:, 2] <= f_road(p[:, 0] - pos[0])

    steps = np.geomspace(1e-2, 1e4, 4000)
    pts = pos + steps[None, :, None] * dirs[:, None, :]
    hit = pts[..., 2] <= f_road(pts[..., 0] - pos[0])
    first = np.argmax(hit, axis=1)
    assert hit[np.arange(len(uv)), first].all()
    assert (first > 0).all()
    lo, hi = steps[first - 1], steps[first]
    for _ in range(100):
        mid = 0.5 * (lo + hi)
        under = below(mid)
        hi = np.where(under, mid, hi)
        lo = np.where(under, lo, mid)
    return pos[:2] + hi[:, None] * dirs[:, :2]


@FAST
@given(cam=cameras(offset=True), seed=st.integers(0, 2**31), grade=st.floats(-0.06, 0.08))
def test_linear_slope_compensation_recovers_points_on_a_sloped_plane(
    cam: CameraModel, seed: int, grade: float
) -> None:
    uv = _below_horizon(cam, seed)
    dirs = cam.rays(uv)
    h = cam.extrinsics.height_m
    # road z = grade * (x - x_cam) in the vehicle frame; keep rays that meet it ahead
    denom = grade * dirs[:, 0] - dirs[:, 2]
    hits = denom > 1e-3
    uv, dirs, denom = uv[hits], dirs[hits], denom[hits]
    t = h / denom
    true_xy = cam.extrinsics.position[:2] + t[:, None] * dirs[:, :2]
    flat = np.stack(image_to_ground(cam, uv)[:2], axis=1)
    got = compensate_points(cam, flat, LinearRoad(h), (grade,))
    np.testing.assert_allclose(got, true_xy, rtol=1e-9, atol=1e-9)
    x0, y0 = cam.extrinsics.x_m, cam.extrinsics.y_m
    xs, ys = compensate_linear(flat[:, 0] - x0, flat[:, 1] - y0, grade, h)
    np.testing.assert_allclose(np.stack([xs + x0, ys + y0], axis=1), true_xy, rtol=1e-9, atol=1e-9)


@FAST
@given(
    cam=cameras(),
    seed=st.integers(0, 2**31),
    grade=st.floats(-0.04, 0.06),
    curv=st.floats(-1e-3, 1e-3),
)
def test_quadratic_road_matches_ray_casting_and_the_numeric_solver(
    cam: CameraModel, seed: int, grade: float, curv: float
) -> None:
    h = cam.extrinsics.height_m
    road = QuadraticRoad(h)
    uv = _below_horizon(cam, seed)
    xf, yf, _ = image_to_ground(cam, uv)
    x, y = compensate(road, xf, yf, (grade, curv))
    hit = np.isfinite(x) & (x < 150.0)
    want = _cast_onto_road(cam, uv[hit], lambda dx: road_height(road, dx, (grade, curv)))
    np.testing.assert_allclose(np.stack([x[hit], y[hit]], axis=1), want, rtol=1e-8, atol=1e-8)
    numeric = ray_scale_numeric(road, xf, (grade, curv))
    closed = road.ray_scale(xf, (grade, curv))
    # A ray that grazes a crest meets the road in a double root, which bracketing on a grid
    # cannot resolve; compare where the two roots are distinct (relative discriminant > 1e-3).
    lin = grade * xf + h
    distinct = lin * lin + 4.0 * curv * h * xf * xf > 1e-3 * lin * lin
    both = hit & distinct
    np.testing.assert_allclose(numeric[both], closed[both], rtol=1e-9)


def test_uphill_pulls_points_closer_and_downhill_pushes_them_out() -> None:
    x = np.array([10.0, 20.0, 40.0])
    y = np.array([1.0, -1.0, 2.0])
    up_x, up_y = compensate_linear(x, y, 0.05, 1.5)
    down_x, _ = compensate_linear(x, y, -0.02, 1.5)
    assert (up_x < x).all()
    assert (down_x > x).all()
    np.testing.assert_allclose(up_y / y, up_x / x)  # the same ray scale for x and y
    flat_x, flat_y = compensate_linear(x, y, 0.0, 1.5)
    np.testing.assert_array_equal(flat_x, x)
    np.testing.assert_array_equal(flat_y, y)


def test_rays_that_never_meet_a_steep_downhill_are_nan() -> None:
    x = np.array([10.0, 100.0])
    xs, ys = compensate_linear(x, np.zeros(2), -0.03, 1.5)  # 1 - 0.03 * 100 / 1.5 < 0
    assert np.isfinite(xs[0])
    assert np.isnan(xs[1])
    assert np.isnan(ys[1])
    assert np.isnan(QuadraticRoad(1.5).ray_scale(x, (-0.03, 0.0))[1])
    assert np.isnan(ray_scale_numeric(LinearRoad(1.5), x, (-0.03,))[1])


def test_road_models_check_their_parameter_count() -> None:
    from superlane_tools.camera import CameraError, RoadModel

    assert isinstance(LinearRoad(1.5), RoadModel)
    assert isinstance(QuadraticRoad(1.5), RoadModel)
    with pytest.raises(CameraError, match="1 parameter"):
        LinearRoad(1.5).f_z(np.ones(2), (0.1, 0.2))
    with pytest.raises(CameraError, match="2 parameter"):
        QuadraticRoad(1.5).ray_scale(np.ones(2), (0.1,))


def test_sim_default_horizon_and_ground_point() -> None:
    cam = load_camera("sim_default")
    assert cam.horizon_row() == pytest.approx(359.5 - 1000.0 * np.tan(0.06))
    x, y, valid = image_to_ground(cam, ground_to_image(cam, np.array([20.0]), np.array([1.75])))
    assert valid.all()
    assert (x[0], y[0]) == pytest.approx((20.0, 1.75), abs=1e-9)
