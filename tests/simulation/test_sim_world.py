"""World and motion: consistent ego kinematics, traffic, lane truth, determinism."""

from __future__ import annotations

import numpy as np
import pytest

from superlane_tools.camera.model import CameraModel, Extrinsics, Intrinsics
from superlane_tools.simulation.errors import ScenarioError
from superlane_tools.simulation.groundtruth import h_samples, lane_truth, tusimple_lanes
from superlane_tools.simulation.motion import ego_state
from superlane_tools.simulation.scenarios import SCENARIOS, get_scenario
from superlane_tools.simulation.world import build_world, frame_world

CAMERA = CameraModel(
    Intrinsics(1280, 720, 1000.0, 1000.0, 639.5, 359.5), Extrinsics(1.5, 0.06), "sim_default"
)


@pytest.mark.parametrize("name", list(SCENARIOS))
def test_ego_kinematics_are_consistent(name: str) -> None:
    world = build_world(SCENARIOS[name], 5, 20.0)
    path = world.path
    stops = SCENARIOS[name].traffic.stop_every_s > 0  # stop_and_go stands at lights
    assert path.speed_mps.min() >= (0.0 if stops else 5.0)
    assert path.speed_mps.max() <= 35.0
    # speed integrates to the path length driven
    s_drive = np.interp(path.s_m, world.road.s_m, path.sigma_m)
    travelled = np.diff(s_drive)
    assert np.allclose(
        travelled / 0.01, 0.5 * (path.speed_mps[1:] + path.speed_mps[:-1]), rtol=1e-2
    )
    st = ego_state(world.road, path, 10.0)
    assert st.yaw_rate_rps == pytest.approx(st.curvature * st.speed_mps)
    # ego curvature stays near the road's (lane changes and wander add a little)
    road_k = np.interp(path.s_m, world.road.s_m, world.road.curvature)
    ego_k = np.interp(path.s_m, world.road.s_m, path.curvature)
    assert np.max(np.abs(ego_k - road_k)) < 2e-3


def test_world_is_deterministic_and_seed_dependent() -> None:
    a = build_world(SCENARIOS["urban"], 11, 10.0)
    b = build_world(SCENARIOS["urban"], 11, 10.0)
    c = build_world(SCENARIOS["urban"], 12, 10.0)
    assert np.array_equal(a.road.x_m, b.road.x_m)
    assert np.array_equal(a.path.s_m, b.path.s_m)
    assert len(a.tracks) == len(b.tracks)
    assert not np.array_equal(a.road.x_m, c.road.x_m)


def test_preceding_vehicle_limits_the_corridor_and_cut_in_happens() -> None:
    world = build_world(SCENARIOS["highway_straight"], 2, 20.0)
    gaps = [frame_world(world, t, 0, CAMERA, 0).lead_gap_m for t in np.arange(0.0, 20.0, 0.5)]
    gaps_arr = np.asarray(gaps)
    assert np.all(np.isfinite(gaps_arr))
    assert gaps_arr.min() < 25.0  # the cut-in vehicle comes close


def test_lane_truth_on_a_straight_road_recovers_offsets() -> None:
    world = build_world(SCENARIOS["highway_straight"], 0, 10.0)
    fw = frame_world(world, 5.0, 0, CAMERA, 0)
    truth = lane_truth(fw)
    lat = fw.state.lateral_m
    expected = [0.0, -3.7, -7.4, -11.1]
    got = np.asarray(truth.offsets_m)
    assert len(got) == 4
    # offsets are relative to the ego, in the vehicle frame (small heading from wander)
    assert np.allclose(got, np.asarray(expected) - lat, atol=0.1)
    assert abs(truth.curvature) < 1e-3
    assert truth.ego_left >= 0
    assert truth.ego_right == truth.ego_left + 1
    assert got[truth.ego_left] > 0 > got[truth.ego_right]


def test_lane_truth_curvature_matches_the_road() -> None:
    world = build_world(SCENARIOS["highway_curves"], 4, 20.0)
    errors = []
    for t in np.arange(0.0, 16.0, 1.0):
        fw = frame_world(world, float(t), 0, CAMERA, 0)
        truth = lane_truth(fw)
        s = fw.state.pose.s_m + np.linspace(5.0, 60.0, 50)
        road_k = float(np.mean(np.interp(s, world.road.s_m, world.road.curvature)))
        errors.append(truth.curvature - road_k)
    assert np.max(np.abs(errors)) < 6e-4


def test_tusimple_points_lie_on_projected_lines() -> None:
    world = build_world(SCENARIOS["highway_curves"], 4, 10.0)
    fw = frame_world(world, 3.0, 0, CAMERA, 0)
    truth = lane_truth(fw)
    rows = h_samples(720)
    lanes = tusimple_lanes(fw.scene.road, CAMERA, truth.profile_index, rows)
    assert len(lanes) == len(truth.offsets_m)
    assert all(len(ln) == len(rows) for ln in lanes)
    ego = lanes[truth.ego_left]
    assert sum(c != -2 for c in ego) > 20
    # near the bottom the ego's left line is left of centre, the right line right of it
    assert ego[-1] < 640 < lanes[truth.ego_right][-1] or ego[-1] == -2


def test_bad_durations_are_refused() -> None:
    with pytest.raises(ScenarioError):
        build_world(get_scenario("urban"), 0, 0.0)
    with pytest.raises(ScenarioError, match="unknown scenario"):
        get_scenario("moon")
