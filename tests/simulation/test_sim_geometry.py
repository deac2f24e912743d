"""Geometry is exact: projected ground-truth lines land on the rendered lane-marking pixels."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.ndimage import distance_transform_edt

from superlane_tools.camera.profiles import load_camera
from superlane_tools.hierarchy import LEAF_IDS, leaf_ids_under
from superlane_tools.simulation.groundtruth import lane_truth, painted_mask
from superlane_tools.simulation.render import render
from superlane_tools.simulation.road import line_points
from superlane_tools.simulation.scenarios import SCENARIOS
from superlane_tools.simulation.world import build_world, frame_world

MARKING_IDS = np.array(leaf_ids_under("lane_marking"))
OCCLUDERS = np.array(
    [
        LEAF_IDS[n]
        for n in (
            "vehicle",
            "person",
            "building_wall_fence",
            "vegetation",
            "pole_sign_utility",
            "sky",
        )
    ]
)


@pytest.mark.parametrize(
    ("scenario", "seed", "t_s"),
    [("highway_curves", 4, 9.0), ("hills", 1, 6.0), ("merge_split", 2, 4.0)],
)
def test_projected_lines_hit_lane_marking_pixels(scenario: str, seed: int, t_s: float) -> None:
    camera = load_camera("sim_default")
    world = build_world(SCENARIOS[scenario], seed, 20.0)
    fw = frame_world(world, t_s, 0, camera, 7)
    frame = render(fw.scene)
    marking = np.isin(frame.labels, MARKING_IDS)
    dist = distance_transform_edt(~marking)
    truth = lane_truth(fw)
    hits, total = 0, 0
    for k in truth.profile_index:
        line = fw.scene.road.lines[k]
        s = np.arange(fw.state.pose.s_m + 4.0, fw.state.pose.s_m + 60.0, 0.25)
        s_on, pts = line_points(fw.scene.road, line, s)
        # only where paint is: inside dashes, away from dash ends by 0.3 m
        painted = painted_mask(str(line.style), line.dash_m, line.gap_m, line.phase_m, s_on)
        inner = (
            painted_mask(
                str(line.style), line.dash_m - 0.6, line.gap_m + 0.6, line.phase_m + 0.3, s_on
            )
            if line.dash_m > 0
            else painted
        )
        uv, front = camera.project(pts)
        u = np.round(uv[:, 0]).astype(int)
        v = np.round(uv[:, 1]).astype(int)
        inside = front & (u >= 0) & (u < camera.width) & (v >= 0) & (v < camera.height)
        sel = painted & inner & inside
        sel[sel] &= ~np.isin(frame.labels[v[sel], u[sel]], OCCLUDERS)
        total += int(sel.sum())
        hits += int((dist[v[sel], u[sel]] <= 2.0).sum())
    assert total > 100
    assert hits / total >= 0.95, (hits, total)
