"""Road geometry: clothoid integration, bounds, and the road profile in the vehicle frame."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from superlane_tools.simulation.errors import ScenarioError
from superlane_tools.simulation.road import (
    MAX_CURVATURE,
    MAX_GRADE,
    EgoPose,
    RoadRecipe,
    _integrate_plan,
    build_road,
    line_points,
    road_ahead,
)
from superlane_tools.simulation.scenarios import SCENARIOS


@settings(max_examples=25, deadline=None)
@given(
    k=st.floats(-MAX_CURVATURE, MAX_CURVATURE).filter(lambda v: abs(v) > 1e-5),
    h0=st.floats(-3.0, 3.0),
)
def test_constant_curvature_integrates_to_a_circle(k: float, h0: float) -> None:
    s = np.arange(0.0, 400.0, 0.1)
    heading, x, y = _integrate_plan(s, np.full_like(s, k), h0)
    # exact circle through the origin with initial heading h0
    x_true = (np.sin(h0 + k * s) - np.sin(h0)) / k
    y_true = (np.cos(h0) - np.cos(h0 + k * s)) / k
    assert np.max(np.hypot(x - x_true, y - y_true)) < 1e-3
    assert np.allclose(heading, h0 + k * s)


def test_clothoid_matches_fresnel_integrals() -> None:
    from scipy.special import fresnel

    a = 1.0 / 150.0 / 200.0  # curvature rate, 1/m^2: reaches the limit after 200 m
    s = np.arange(0.0, 200.0, 0.1)
    _, x, y = _integrate_plan(s, a * s, 0.0)
    scale = np.sqrt(np.pi / a)
    fs, fc = fresnel(s / scale)
    assert np.max(np.hypot(x - scale * fc, y - scale * fs)) < 1e-3


@pytest.mark.parametrize("name", list(SCENARIOS))
def test_every_scenario_road_respects_limits(name: str) -> None:
    road = build_road(SCENARIOS[name].road, 900.0, np.random.default_rng(3))
    assert np.max(np.abs(road.curvature)) <= MAX_CURVATURE + 1e-12
    assert np.max(np.abs(road.grade)) <= MAX_GRADE + 1e-12
    assert np.all(np.abs(np.diff(road.curvature)) < 1e-4)  # curvature continuous
    assert all(2.8 <= w <= 3.9 for w in road.lane_widths_m)
    assert road.left_edge_m > 0 > road.right_edge_m


def test_hills_have_crests_and_sags() -> None:
    road = build_road(SCENARIOS["hills"].road, 1500.0, np.random.default_rng(0))
    assert road.grade.max() > 0.02
    assert road.grade.min() < -0.02


def test_urban_has_crosswalks_and_stop_lines_with_line_gaps() -> None:
    road = build_road(SCENARIOS["urban"].road, 900.0, np.random.default_rng(0))
    assert road.stop_lines_s_m
    assert road.crosswalks_s_m
    stop = road.stop_lines_s_m[0]
    assert not any(ln.start_s_m <= stop + 10.0 < ln.end_s_m for ln in road.lines)


def test_merge_tapers_the_right_edge_inwards() -> None:
    road = build_road(SCENARIOS["merge_split"].road, 1200.0, np.random.default_rng(0))
    tapered = [ln for ln in road.lines if not np.isnan(ln.taper_start_s_m)]
    assert len(tapered) == 2
    merge = tapered[0]
    before = merge.offset_at(np.array([merge.taper_start_s_m - 1.0]))[0]
    after = merge.offset_at(np.array([merge.taper_start_s_m + merge.taper_length_m + 1.0]))[0]
    assert after - before == pytest.approx(road.lane_widths_m[-1])


@pytest.mark.parametrize(
    "recipe",
    [
        RoadRecipe(lane_widths_m=(3.5,)),
        RoadRecipe(lane_widths_m=(3.5, 4.5)),
        RoadRecipe(lane_widths_m=(3.5,) * 6),
    ],
)
def test_impossible_recipes_are_refused(recipe: RoadRecipe) -> None:
    with pytest.raises(ScenarioError):
        build_road(recipe, 500.0, np.random.default_rng(0))


def test_road_ahead_is_in_the_vehicle_frame() -> None:
    road = build_road(SCENARIOS["highway_curves"].road, 900.0, np.random.default_rng(1))
    s0 = 300.0
    smp = road.sample(np.array([s0]))
    pose = EgoPose(
        s0,
        float(smp["x"][0]),
        float(smp["y"][0]),
        float(smp["z"][0]),
        float(smp["heading"][0]),
        float(np.arctan(smp["grade"][0])),
    )
    prof = road_ahead(road, pose)
    assert np.all(np.diff(prof.x_m) > 0)
    i0 = int(np.argmin(np.abs(prof.s_m - s0)))
    assert abs(prof.x_m[i0]) < 1e-6
    assert abs(prof.y_m[i0]) < 1e-6
    assert abs(prof.z_m[i0]) < 1e-6
    assert abs(prof.heading_rad[i0]) < 1e-3
    # lateral offsets are metric: the line through the left edge sits exactly 0 m from the
    # reference line, the next one a lane width to the right
    line = next(ln for ln in prof.lines if ln.offset_m == 0.0)
    _, pts = line_points(prof, line)
    assert np.allclose(pts[:, :2], np.stack([prof.x_m, prof.y_m], 1)[: len(pts)], atol=1e-9)
