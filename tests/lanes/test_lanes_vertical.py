"""The optional vertical-curvature road model ``z = b x + c x^2``: geometry, kernels, fit."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from superlane_tools.camera import CameraModel
from superlane_tools.lanes import (
    CostFunction,
    FitParams,
    FitParamsError,
    Histogram,
    Lane,
    columns_at_rows,
    fit_frame,
)
from superlane_tools.lanes._rays import RayPoints
from superlane_tools.lanes._refit import SharedModel, refit_shared
from superlane_tools.lanes.cost import ray_points, road_den

OFFSETS = (-5.4, -1.8, 1.8, 5.4)


def _render(
    camera: CameraModel, a1: float, a2: float, b: float, c: float, x_max: float = 60.0
) -> np.ndarray:
    """Return lane pixels of parallel lines on the road ``z = b x + c x^2`` (x from the foot)."""
    xs = np.arange(4.0, x_max, 0.02)
    lat = np.linspace(-0.075, 0.075, 5)
    pix = []
    for off in OFFSETS:
        x = np.repeat(xs, lat.size)
        y = off + a1 * x + a2 * x * x + np.tile(lat, xs.size)
        uv, front = camera.project(np.stack([x, y, x * (b + c * x)], axis=1))
        pix.append(uv[front])
    lane = np.unique(np.round(np.concatenate(pix)).astype(np.int64), axis=0)
    inside = (lane[:, 0] >= 0) & (lane[:, 0] < camera.width)
    inside &= (lane[:, 1] >= 0) & (lane[:, 1] < camera.height)
    return lane[inside].astype(np.float64)


def test_ray_meets_the_curved_road_at_the_nearer_root(camera_factory) -> None:
    cam = camera_factory()
    h = cam.extrinsics.height_m
    for b, c in ((0.01, -4e-4), (-0.02, 3e-4), (0.0, 1e-4)):
        x = np.array([5.0, 20.0, 35.0, 45.0])
        y = np.array([1.0, -2.0, 3.5, 0.5])
        uv, front = cam.project(np.stack([x, y, x * (b + c * x)], axis=1))
        assert front.all()
        pts = RayPoints(cam, uv, FitParams(vertical_curvature_bound=5e-4, max_range_m=200.0))
        assert pts.size == x.size
        xr, yr, ok = ray_points(pts.iq, pts.r, b, h, 200.0, c)
        assert ok.all()
        np.testing.assert_allclose(xr, x, rtol=1e-9)
        np.testing.assert_allclose(yr, y, rtol=1e-9, atol=1e-9)
    # Continuous as c -> 0 and exactly the linear road at c = 0.
    den = np.array([0.01, 0.1, 0.5])
    np.testing.assert_allclose(road_den(den, 1e-15), den, rtol=1e-9)
    assert road_den(den, 0.0) is den
    # A ray above the crest misses the road.
    assert road_den(np.array([0.001]), -1e-3)[0] == -1.0


@pytest.mark.parametrize("n_road", [0, 200])
def test_kernel_cost_matches_numpy_reference_with_vertical_curvature(n_road: int) -> None:
    rng = np.random.default_rng(11)
    iq = rng.uniform(-0.01, 0.5, 600)
    r = rng.normal(0.0, 0.3, 600)
    cost = CostFunction(
        iq,
        r,
        1.5,
        200.0,
        Histogram.symmetric(15.0, 0.1),
        2.0,
        rng.uniform(0.005, 0.3, n_road) if n_road else None,
        rng.normal(0.0, 0.1, n_road) if n_road else None,
        lambda_road=0.001,
    )
    thetas = np.stack(
        [
            rng.uniform(-0.2, 0.2, 48),
            rng.uniform(-0.01, 0.01, 48),
            rng.uniform(-0.04, 0.04, 48),
            rng.uniform(-5.0, 5.0, 48),
            rng.uniform(-5e-4, 5e-4, 48),
        ],
        axis=1,
    )
    reference = np.array([cost.reference(t) for t in thetas])
    np.testing.assert_allclose([cost(t) for t in thetas], reference, rtol=0, atol=1e-9)
    np.testing.assert_allclose(cost.batch(thetas), reference, rtol=0, atol=1e-9)
    np.testing.assert_allclose(cost.reference_batch(thetas), reference, rtol=0, atol=1e-9)
    # c matters, and c = 0 in a fifth column is the four-parameter cost.
    flat = thetas.copy()
    flat[:, 4] = 0.0
    assert np.max(np.abs(cost.batch(flat) - reference)) > 1e-3
    np.testing.assert_allclose(cost.batch(flat), cost.batch(thetas[:, :4]), rtol=0, atol=0)


def test_refit_backends_agree_with_vertical_curvature(camera_factory) -> None:
    cam = camera_factory()
    uv = _render(cam, 0.01, 1.0 / 800, 0.01, -3e-4)
    p = FitParams(vertical_curvature_bound=5e-4)
    pts = RayPoints(cam, uv, p)
    x, y, _ = ray_points(pts.iq, pts.r, 0.0, 1.5, 200.0)
    labels = np.argmin(np.abs((y - x * 0.01)[:, None] - np.array(OFFSETS)[None, :]), axis=1)
    start = SharedModel(0.0, 0.0, 0.0, np.array(OFFSETS), 0.0)
    args = (pts.iq, pts.r, labels, 4, start, 1.5, 2, True, 0.04, 200.0)
    numpy_fit = refit_shared(*args, vertical_bound=5e-4)
    compiled = refit_shared(*args, compiled=True, vertical_bound=5e-4)
    for name in ("a1", "a2", "b", "c"):
        assert getattr(compiled, name) == pytest.approx(getattr(numpy_fit, name), abs=1e-9)
    assert numpy_fit.c == pytest.approx(-3e-4, abs=8e-5)
    assert numpy_fit.b == pytest.approx(0.01, abs=4e-3)
    # Off: c stays where it started.
    assert refit_shared(*args, compiled=True).c == 0.0


@pytest.mark.parametrize(("b", "c"), [(0.0, -3.5e-4), (0.006, 2.5e-4), (0.01, -2e-4)])
def test_vertical_curve_fit_removes_the_curvature_leak(camera_factory, b, c) -> None:
    """On ``z = b x + c x^2`` the linear road model leaks ``c`` into ``a2``; the term fixes it."""
    cam = camera_factory()
    a1, a2 = 0.01, 1.0 / 1000
    uv = _render(cam, a1, a2, b, c)
    linear = fit_frame(uv, None, cam, FitParams(max_range_m=60.0))
    params = FitParams(max_range_m=60.0, vertical_curvature_bound=5e-4)
    vertical = fit_frame(uv, None, cam, params)
    assert linear.c == 0.0
    # b and c are correlated over 4-60 m: pixel rounding moves them together.
    assert vertical.c == pytest.approx(c, abs=8e-5)
    assert vertical.b == pytest.approx(b, abs=4e-3)
    err_linear = abs(linear.curvature - 2 * a2)
    err_vertical = abs(vertical.curvature - 2 * a2)
    assert err_linear > 2.5e-4  # the leak this term removes
    assert err_vertical < 0.25 * err_linear
    # The numpy reference gives the same fit; a warm start from it stays there.
    reference = fit_frame(uv, None, cam, replace(params, backend="numpy"))
    for name in ("a1", "a2", "b", "c", "cost"):
        assert getattr(vertical, name) == pytest.approx(getattr(reference, name), abs=1e-8)
    warm = fit_frame(uv, None, cam, params, init=vertical)
    assert warm.c == pytest.approx(vertical.c, abs=2e-5)
    # Drawn back on the same road model, each line lands on its pixels.
    lane = Lane(OFFSETS[1], a1, a2, 5.0, 55.0)
    xs = np.array([8.0, 25.0, 50.0])
    truth, _ = cam.project(np.stack([xs, OFFSETS[1] + a1 * xs + a2 * xs**2, xs * (b + c * xs)], 1))
    cols = columns_at_rows(lane, b, cam, truth[:, 1], vertical_curvature=c)
    np.testing.assert_allclose(cols, truth[:, 0], atol=0.1)


def test_vertical_curvature_params_are_validated() -> None:
    assert not FitParams().vertical
    assert FitParams(vertical_curvature_bound=5e-4).vertical
    with pytest.raises(FitParamsError, match="vertical_curvature_bound"):
        FitParams(vertical_curvature_bound=0.02)
    with pytest.raises(FitParamsError, match="needs slope"):
        FitParams(vertical_curvature_bound=5e-4, slope=False)
    with pytest.raises(FitParamsError, match="grid"):
        FitParams(grid_vertical=0)
