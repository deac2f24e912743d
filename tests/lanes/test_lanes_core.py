"""Unit tests of the lane-fit building blocks: cost, peaks, attributes, projection, reasons."""

from __future__ import annotations

import math

import numpy as np
import pytest

from superlane_tools.lanes import (
    CODE_OF,
    CostFunction,
    FitParams,
    FitParamsError,
    Histogram,
    Lane,
    LaneFitError,
    columns_at_rows,
    compensate,
    find_offsets,
    fit_frame,
    soft_histogram,
)
from superlane_tools.lanes.attributes import marking_from_codes, style_from_support
from superlane_tools.lanes.cost import ray_points


def test_soft_histogram_splits_between_neighbours() -> None:
    hist = Histogram.symmetric(1.0, 0.5)  # centres -1, -0.5, 0, 0.5, 1
    counts = soft_histogram(np.array([0.125, 5.0, np.nan]), hist)
    np.testing.assert_allclose(counts, [0, 0, 0.75, 0.25, 0])


def test_batch_cost_equals_single_evaluations() -> None:
    rng = np.random.default_rng(3)
    iq = rng.uniform(1 / 80, 1 / 5, 400)
    r = rng.normal(0.0, 0.2, 400)
    cost = CostFunction(
        iq,
        r,
        1.5,
        200.0,
        Histogram.symmetric(15, 0.1),
        2.0,
        iq[:100],
        r[:100],
        lambda_road=0.001,
    )
    thetas = np.array([[0.0, 0.0, 0.0, 0.0], [0.02, -0.001, 0.03, 0.5], [-0.1, 0.002, -0.04, 1]])
    np.testing.assert_allclose(cost.batch(thetas), [cost(t) for t in thetas], rtol=1e-9)


@pytest.mark.parametrize("jacobian", [False, True])
def test_entropy_is_lowest_at_true_parameters(camera_factory, renderer, jacobian: bool) -> None:
    cam = camera_factory()
    lane_uv, _ = renderer(cam, [-1.8, 1.9, 5.6], 0.02, 0.001, 0.02)
    from superlane_tools.lanes._rays import RayPoints

    pts = RayPoints(cam, lane_uv, FitParams())
    cost = CostFunction(
        pts.iq, pts.r, 1.5, 200.0, Histogram.symmetric(15, 0.1), 2.0, jacobian=jacobian
    )
    best = cost(np.array([0.02, 0.001, 0.02, 0.0]))
    for delta in ([0.01, 0, 0, 0], [0, 0.0005, 0, 0], [0, 0, 0.01, 0]):
        assert cost(np.array([0.02, 0.001, 0.02, 0.0]) + np.array(delta)) > best


def test_pixel_entropy_is_blind_to_a_shrinking_far_field() -> None:
    """Noise 60 m ahead: a slope shrinks it and its entropy per metre, not its entropy per pixel."""
    rng = np.random.default_rng(4)
    iq = np.full(2000, 1 / 60.0)
    r = rng.normal(0.0, 0.02, 2000)
    slopes = (0.0, 0.02, 0.04)
    per_m, per_px = (
        np.array(
            [
                CostFunction(iq, r, 1.5, 200.0, Histogram.symmetric(15, 0.1), 2.0, jacobian=j)(
                    np.array([0.0, 0.0, b, 0.0])
                )
                for b in slopes
            ]
        )
        for j in (False, True)
    )
    assert np.all(np.diff(per_m) < -0.3)  # 60 m -> 33 m: log(60 / 33) = 0.6 nats less
    assert np.ptp(per_px) < 0.05


def test_ray_form_matches_paper_eq10() -> None:
    xf = np.array([5.0, 20.0, 50.0])
    yf = np.array([1.0, -2.0, 3.0])
    x, y, ok = compensate(xf, yf, 0.03, 1.5)
    xr, yr, okr = ray_points(1 / xf, yf / xf, 0.03, 1.5, 1000.0)
    np.testing.assert_allclose(x, xr)
    np.testing.assert_allclose(y, yr)
    assert ok.all()
    assert okr.all()
    # Eq. 10 in the paper's frame: y_fwd = yt / (yt b / h + 1), x_lat = xt (h - b y_fwd) / h.
    np.testing.assert_allclose(x, xf / (xf * 0.03 / 1.5 + 1))
    np.testing.assert_allclose(y, yf * (1.5 - 0.03 * x) / 1.5)


def test_find_offsets_keeps_small_outer_line() -> None:
    rng = np.random.default_rng(0)
    res = np.concatenate(
        [
            rng.normal(-1.8, 0.03, 900),
            rng.normal(1.9, 0.03, 900),
            rng.normal(5.6, 0.03, 12),
        ]
    )
    offsets = find_offsets(res, FitParams())
    np.testing.assert_allclose(offsets, [-1.8, 1.9, 5.6], atol=0.03)


def test_find_offsets_respects_minimum_separation() -> None:
    res = np.concatenate([np.full(500, 0.0), np.full(500, 1.5)])
    assert find_offsets(res, FitParams()).size == 1


def test_marking_attributes() -> None:
    codes = np.array([CODE_OF["dividing_yellow_solid"]] * 5 + [CODE_OF["dividing_white_dashed"]])
    assert marking_from_codes(codes) == ("yellow", "solid")
    assert marking_from_codes(np.zeros(4, dtype=np.intp)) == ("unknown", "unknown")
    assert style_from_support(np.arange(300, 700)) == "solid"
    dashed = np.concatenate([np.arange(300, 340), np.arange(400, 450), np.arange(550, 650)])
    assert style_from_support(dashed) == "dashed"


def test_dashed_style_from_pixel_support(camera_factory, renderer) -> None:
    cam = camera_factory()
    solid, _ = renderer(cam, [-1.8], 0.0, 0.0, 0.0)
    dashed, _ = renderer(cam, [1.9], 0.0, 0.0, 0.0, dashed=True)
    fit = fit_frame(np.concatenate([solid, dashed]), None, cam)
    assert [ln.style for ln in fit.lanes] == ["dashed", "solid"]


def test_projection_round_trip(camera_factory) -> None:
    cam = camera_factory()
    lane = Lane(offset_m=1.8, a1=0.01, a2=0.0005, range_min_m=6.0, range_max_m=50.0)
    x = np.array([8.0, 20.0, 40.0])
    pts = np.stack([x, 1.8 + 0.01 * x + 0.0005 * x * x, 0.02 * x], axis=1)
    uv, _ = cam.project(pts)
    cols = columns_at_rows(lane, 0.02, cam, uv[:, 1])
    np.testing.assert_allclose(cols, uv[:, 0], atol=0.05)
    far, _ = cam.project(np.array([[80.0, 1.8, 1.6]]))
    assert math.isnan(columns_at_rows(lane, 0.02, cam, far[:, 1])[0])
    assert math.isnan(columns_at_rows(lane, 0.02, cam, np.array([719.0]))[0])


def test_reasons_for_unfittable_frames(camera_factory, renderer) -> None:
    cam = camera_factory()
    assert fit_frame(np.empty((0, 2)), None, cam).reason == "no lane pixels"
    assert fit_frame(np.array([[640.0, 100.0]]), None, cam).reason == "no lane pixels"
    one, road = renderer(cam, [-1.8], 0.01, 0.0, 0.0)
    fit = fit_frame(one, None, cam)
    assert fit.reason == "one line"
    assert len(fit.lanes) == 1
    assert abs(fit.lanes[0].offset_m + 1.8) < 0.1
    assert fit.ego_right == 0
    assert fit.ego_left == -1
    assert math.isnan(fit.lane_width_m)
    only_road = fit_frame(np.empty((0, 2)), road, cam)
    assert only_road.reason == "all road"
    assert not only_road.lanes
    assert abs(only_road.road_centre_m + 1.8) < 0.5


def test_warm_start_converges_faster(camera_factory, renderer) -> None:
    cam = camera_factory()
    lane_uv, _ = renderer(cam, [-1.8, 1.9], 0.02, 0.001, 0.01)
    cold = fit_frame(lane_uv, None, cam)
    warm = fit_frame(lane_uv, None, cam, init=cold)
    assert warm.evaluations < cold.evaluations
    assert abs(warm.a1 - cold.a1) < 1e-3


def test_bad_inputs() -> None:
    with pytest.raises(FitParamsError):
        FitParams(order=3)
    with pytest.raises(FitParamsError):
        FitParams.from_dict({"sigma": 1})
    from superlane_tools.camera import load_camera

    with pytest.raises(LaneFitError):
        fit_frame(np.array([[np.nan, 1.0]]), None, load_camera("sim_default"))
