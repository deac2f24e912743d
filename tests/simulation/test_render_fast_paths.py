"""The renderer's fast paths give the same geometry as the plain per-pixel formulas."""

from __future__ import annotations

import time
from dataclasses import replace

import numpy as np
import pytest

from superlane_tools.camera.model import CameraModel, Extrinsics, Intrinsics
from superlane_tools.hierarchy import LEAF_IDS
from superlane_tools.simulation.render import render
from superlane_tools.simulation.render._rays import camera_rays
from superlane_tools.simulation.render.examples import DEFAULT_CAMERA, example_scene
from superlane_tools.simulation.render.raycast import (
    RoadHit,
    cast_road,
    footprint,
    footprint_at,
    road_tables,
)
from superlane_tools.simulation.render.road_shading import (
    DEFAULT_PALETTE,
    GroundLight,
    ground_labels,
    line_label,
    shade_ground,
)
from superlane_tools.simulation.render.textures import road_textures
from superlane_tools.simulation.scene import Conditions, FrameScene, LineStyle, SceneObject

DISTORTED = CameraModel(
    Intrinsics(960, 540, 760.0, 760.0, 481.0, 268.0, (-0.12, 0.03, 0.001, -0.0005, 0.0)),
    Extrinsics(height_m=1.35, pitch_rad=0.04, roll_rad=0.01),
)
SMALL = DEFAULT_CAMERA.resized(640, 360)


def _hit(scene: FrameScene) -> RoadHit:
    return cast_road(camera_rays(scene.camera), road_tables(scene.road))


def _dense_line_labels(scene: FrameScene, hit: RoadHit) -> np.ndarray:
    """Ground labels with every line evaluated on every pixel (the reference formulas)."""
    road = scene.road
    labels, _, _ = ground_labels(hit, road)
    s, l_m = hit.s_m, hit.l_m
    foot_l = footprint(l_m, hit.hit)
    in_view = hit.hit & (s >= road.s_m[0]) & (s <= road.s_m[-1])
    for line in road.lines:
        hw = 0.5 * line.width_m
        d = np.abs(l_m - np.float32(line.offset_m))
        if line.style is LineStyle.DOUBLE:
            d = np.abs(d - np.float32(hw + 0.075))
        mark = d < np.maximum(np.float32(hw), np.float32(0.5) * foot_l)
        if line.style is LineStyle.DASHED:
            m = s - np.float32(line.phase_m)
            period = line.dash_m + line.gap_m
            m = m - np.floor(m * np.float32(1.0 / period)) * np.float32(period)
            mark &= m < line.dash_m
        mark &= in_view
        labels[mark] = line_label(line)
    return labels


@pytest.mark.parametrize(
    ("kind", "camera"),
    [
        ("straight", DEFAULT_CAMERA),
        ("curve", DEFAULT_CAMERA),
        ("hill", SMALL),
        ("curve", DISTORTED),
    ],
)
def test_sparse_line_painting_gives_the_dense_labels(kind: str, camera: CameraModel) -> None:
    scene = example_scene(kind, camera=camera, with_objects=False, s0_m=1111.3)
    hit = _hit(scene)
    frame = render(scene)
    ref = _dense_line_labels(scene, hit)
    got = frame.labels[hit.row0 :]
    assert np.array_equal(got[hit.hit], ref[hit.hit])
    assert np.isin(ref, list(range(13, 20))).sum() > 1000


def test_footprint_at_matches_the_dense_footprint() -> None:
    hit = _hit(example_scene("curve", camera=DISTORTED, with_objects=False))
    rows, cols = hit.l_m.shape
    rng = np.random.default_rng(3)
    idx = np.concatenate(
        [
            rng.integers(0, rows * cols, 5000),
            np.arange(cols - 1, rows * cols, cols),  # last column
            np.arange((rows - 1) * cols, rows * cols),  # last row
        ]
    )
    for a in (hit.l_m, hit.s_m):
        dense = footprint(a, hit.hit).reshape(-1)[idx]
        assert np.array_equal(footprint_at(a, hit.hit, idx), dense)


def test_stage_times_are_reported() -> None:
    stages: dict[str, float] = {}
    t0 = time.process_time()
    render(example_scene("curve", camera=SMALL, conditions=Conditions(rain=0.5)), stages)
    cpu_ms = (time.process_time() - t0) * 1e3
    assert set(stages) == {"ray_cast", "composite", "objects", "road_shading", "effects", "sensor"}
    # Each stage took some CPU time (ms), and the stages are consecutive parts of the one call.
    assert all(v > 0.0 for v in stages.values()), stages
    assert sum(stages.values()) <= cpu_ms + 1.0


def test_trees_are_green_foliage_with_consistent_labels() -> None:
    base = example_scene("straight", camera=SMALL, with_objects=False)
    tree = SceneObject("vegetation", 25.0, -9.0, 0.0, 6.0, 6.0, 10.0, 0.0, (45, 90, 60), "tree")
    frame = render(replace(base, objects=(tree,)))
    # The distant tree line of the sky is vegetation too: look at the tree only.
    veg = (frame.labels == LEAF_IDS["vegetation"]) & (render(base).labels != frame.labels)
    assert veg.sum() > 2000
    b, g, r = (frame.image_bgr[veg].astype(float).mean(axis=0)).tolist()
    assert g > r
    assert g > b
    # Foliage is irregular: the crown does not fill its bounding box like a disc or a box.
    vv, uu = np.nonzero(veg)
    box = (vv.max() - vv.min() + 1) * (uu.max() - uu.min() + 1)
    assert 0.3 < veg.sum() / box < 0.85


def test_objects_fade_into_fog_with_distance() -> None:
    base = example_scene("straight", camera=SMALL, with_objects=False)
    fog = Conditions(fog=0.6, noise_sigma=0.0)
    near = SceneObject("vehicle", 15.0, 0.0, 0.0, 4.5, 1.8, 1.5, 0.0, (20, 20, 140), "car")
    far = replace(near, x_m=70.0, y_m=-3.6)
    frame = render(replace(base, objects=(near, far), conditions=fog))
    cars = (frame.labels == LEAF_IDS["vehicle"]).astype(np.uint8)
    import cv2

    n, comp = cv2.connectedComponents(cars)
    sizes = [(comp == i).sum() for i in range(1, n)]
    assert n - 1 >= 2
    order = np.argsort(sizes)[::-1]
    near_px = frame.image_bgr[comp == order[0] + 1].astype(float).mean(axis=0)
    far_px = frame.image_bgr[comp == order[1] + 1].astype(float).mean(axis=0)
    # The far car is closer to the grey fog: less red saturation.
    assert (near_px[2] - near_px[0]) > (far_px[2] - far_px[0]) + 10


def test_raised_pavement_markers_change_the_colour_only() -> None:
    scene = example_scene("curve", with_objects=False, s0_m=1006.0)
    hit = _hit(scene)
    half = hit.range_m[::2, ::2].shape
    light = GroundLight(np.ones(half, np.float32), np.zeros(half, np.float32), (0.0, 0.0, 0.0))
    tex = road_textures(0)
    args = (hit, scene.road, tex, DEFAULT_PALETTE, 0.2, 0.0, 0.0, light)
    dots = shade_ground(*args, road_dots=True)
    plain = shade_ground(*args, road_dots=False)
    assert np.array_equal(dots.labels, plain.labels)
    brighter = (dots.color - plain.color).sum(axis=2)
    changed = brighter > 60.0
    assert changed.sum() > 20
    # Markers lie on road pixels (never on the paint) in the dashed lines' gaps.
    assert np.all(dots.labels[changed] == LEAF_IDS["road"])
