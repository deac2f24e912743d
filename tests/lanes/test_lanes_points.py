"""Label image -> fit points (the one pixel extraction), and the ego helpers of a lane fit."""

from __future__ import annotations

import math

import numpy as np
import pytest

from superlane_tools.hierarchy import LEAF_IDS
from superlane_tools.lanes import CODE_OF, Lane, LaneFit
from superlane_tools.lanes.class_map import mask_points, parse_classes
from superlane_tools.lanes.points import (
    LEAF_LOOKUP,
    MAX_LANE_PIXELS,
    MAX_ROAD_PIXELS,
    ClassLookup,
    label_points,
)


def _labels() -> np.ndarray:
    labels = np.zeros((40, 60), dtype=np.uint8)
    labels[20:, :] = LEAF_IDS["road"]
    labels[25:, 10] = LEAF_IDS["dividing_white_dashed"]
    labels[25:, 50] = LEAF_IDS["dividing_yellow_solid"]
    return labels


def test_leaf_labels_give_lane_pixels_with_codes_and_road_pixels() -> None:
    labels = _labels()
    pts = label_points(labels)
    assert pts.road_uv is not None
    assert pts.lane_uv.shape == (30, 2)
    assert set(pts.lane_uv[:, 0]) == {10.0, 50.0}
    by_column = dict(zip(pts.lane_uv[:, 0], pts.codes, strict=True))
    assert by_column[10.0] == CODE_OF["dividing_white_dashed"]
    assert by_column[50.0] == CODE_OF["dividing_yellow_solid"]
    assert pts.road_uv.shape == (20 * 60, 2)  # road plus the markings on it
    assert label_points(labels, road=False).road_uv is None


def test_a_class_map_gives_the_same_points_as_the_leaf_ids() -> None:
    labels = _labels()
    classes = parse_classes(
        {
            "road": LEAF_IDS["road"],
            "dividing_white_dashed": LEAF_IDS["dividing_white_dashed"],
            "dividing_yellow_solid": LEAF_IDS["dividing_yellow_solid"],
        }
    )
    mine, leaf = mask_points(labels, classes), label_points(labels, LEAF_LOOKUP)
    assert np.array_equal(mine.lane_uv, leaf.lane_uv)
    assert np.array_equal(mine.codes, leaf.codes)
    assert mine.road_uv is not None
    assert leaf.road_uv is not None
    assert np.array_equal(mine.road_uv, leaf.road_uv)


def test_ids_beyond_the_lookup_are_neither_lane_nor_road() -> None:
    lookup = ClassLookup.from_ids({1: 0}, (2,), size=3)
    labels = np.array([[1, 2, 900]], dtype=np.int32)
    pts = label_points(labels, lookup)
    assert pts.lane_uv.tolist() == [[0.0, 0.0]]
    assert pts.road_uv is not None
    assert pts.road_uv.tolist() == [[1.0, 0.0]]


@pytest.mark.parametrize("seed", [0, 7])
def test_caps_subsample_deterministically(seed: int) -> None:
    labels = np.full((400, 300), LEAF_IDS["dividing_white_solid"], dtype=np.uint8)
    first, again = label_points(labels, seed=seed), label_points(labels, seed=seed)
    assert first.lane_uv.shape == (MAX_LANE_PIXELS, 2)
    assert first.road_uv is not None
    assert first.road_uv.shape == (MAX_ROAD_PIXELS, 2)
    assert np.array_equal(first.lane_uv, again.lane_uv)
    other = label_points(labels, seed=seed + 1)
    assert not np.array_equal(first.lane_uv, other.lane_uv)


def _lane(offset: float, near: float, far: float) -> Lane:
    return Lane(offset_m=offset, a1=0.0, a2=0.0, range_min_m=near, range_max_m=far)


def test_ego_helpers_of_a_fit() -> None:
    lanes = (_lane(5.4, 6.0, 40.0), _lane(1.8, 5.0, 50.0), _lane(-1.8, 8.0, 30.0))
    fit = LaneFit(a1=0.01, a2=1e-4, b=0.01, lanes=lanes, ego_left=1, ego_right=2)
    assert fit.ego_lines() == (lanes[1], lanes[2])
    assert fit.ego_support_m() == (8.0, 30.0)
    assert fit.plausible(max_slope=0.05)
    assert not fit.plausible(max_slope=0.005)  # slope at the bound: collapsed view
    assert fit.trackable(max_slope=0.05)
    centre, width, ahead = fit.lane_grid()
    assert width == pytest.approx(3.6)
    assert ahead == pytest.approx(19.0)
    assert centre == pytest.approx(0.0, abs=1e-9)  # lines at +-1.8, 5.4: the grid is centred
    apart = LaneFit(
        a1=0.0,
        a2=0.0,
        b=0.0,
        lanes=(_lane(1.8, 5.0, 9.0), _lane(-1.8, 10.0, 30.0)),
        ego_left=0,
        ego_right=1,
    )
    assert apart.plausible(math.inf)
    assert not apart.trackable(math.inf)  # no common range of the two ego lines
    assert math.isnan(apart.lane_grid()[2])
    none = LaneFit(lanes=(_lane(1.8, 5.0, 9.0),), ego_left=0)
    assert none.ego_lines() is None
    assert all(math.isnan(v) for v in (*none.ego_support_m(), *none.lane_grid()))
    assert not none.plausible(math.inf)
