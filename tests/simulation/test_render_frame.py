"""Whole-frame rendering: labels, occlusion, corridor, conditions, determinism, errors."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from superlane_tools.camera.model import CameraModel
from superlane_tools.hierarchy import LEAF_IDS
from superlane_tools.simulation.errors import ScenarioError
from superlane_tools.simulation.render import render
from superlane_tools.simulation.render.examples import DEFAULT_CAMERA, example_scene
from superlane_tools.simulation.scene import Conditions, SceneObject

SMALL: CameraModel = DEFAULT_CAMERA.resized(640, 360)


def test_output_shapes_types_and_label_classes() -> None:
    frame = render(example_scene("straight", camera=SMALL))
    assert frame.image_bgr.shape == (360, 640, 3)
    assert frame.image_bgr.dtype == np.uint8
    assert frame.labels.shape == (360, 640)
    assert frame.labels.dtype == np.uint8
    assert frame.corridor.dtype == np.bool_
    present = set(np.unique(frame.labels).tolist())
    for name in (
        "sky",
        "road",
        "vehicle",
        "vegetation",
        "building_wall_fence",
        "pole_sign_utility",
        "terrain_ground",
        "dividing_white_solid",
        "dividing_white_dashed",
        "dividing_yellow_solid",
    ):
        assert LEAF_IDS[name] in present, name
    assert 0 not in present  # every pixel is labelled
    assert frame.labels[0, 0] == LEAF_IDS["sky"]


def test_same_scene_gives_identical_bytes_and_frame_seed_changes_only_the_image() -> None:
    scene = example_scene("curve", camera=SMALL, conditions=Conditions(rain=0.5, wet=0.5))
    a, b = render(scene), render(scene)
    assert a.image_bgr.tobytes() == b.image_bgr.tobytes()
    assert a.labels.tobytes() == b.labels.tobytes()
    c = render(replace(scene, frame_seed=99))
    assert c.image_bgr.tobytes() != a.image_bgr.tobytes()
    assert np.array_equal(c.labels, a.labels)


def test_preceding_vehicle_occludes_road_and_cuts_the_corridor() -> None:
    base = example_scene("straight", camera=SMALL, with_objects=False)
    car = SceneObject("vehicle", 15.0, 0.0, 0.0, 4.5, 1.8, 1.5, 0.0, (30, 30, 160), "car")
    scene = replace(base, objects=(car,), corridor_length_m=12.75)
    frame = render(scene)
    uv, _ = SMALL.project(np.array([[12.75, 0.0, 0.7]]))
    u, v = round(uv[0, 0]), round(uv[0, 1])
    assert frame.labels[v, u] == LEAF_IDS["vehicle"]
    assert not frame.corridor[v, u]
    # No corridor above the car's contact row: it stops at the vehicle.
    uv0, _ = SMALL.project(np.array([[12.75, 0.0, 0.0]]))
    assert not frame.corridor[: int(uv0[0, 1]) - 2].any()
    assert frame.corridor[int(uv0[0, 1]) + 5 :].any()


def test_road_hides_a_vehicle_behind_the_crest() -> None:
    base = example_scene("hill", camera=SMALL, with_objects=False)
    road = base.road
    i = int(np.searchsorted(road.x_m, 160.0))
    car = SceneObject(
        "vehicle",
        road.x_m[i],
        road.y_m[i],
        road.z_m[i],
        4.5,
        1.8,
        1.4,
        road.heading_rad[i],
        (30, 30, 160),
        "car",
    )
    frame = render(replace(base, objects=(car,)))
    assert LEAF_IDS["vehicle"] not in np.unique(frame.labels)
    tall = replace(car, height_m=12.0, style="truck")
    frame = render(replace(base, objects=(tall,)))
    assert LEAF_IDS["vehicle"] in np.unique(frame.labels)


@pytest.mark.parametrize(
    ("name", "cond"),
    [
        ("night", Conditions(name="night", daylight=0.05)),
        ("tunnel", Conditions(name="tunnel", tunnel=True, daylight=0.3)),
        (
            "heavy_rain",
            Conditions(
                name="heavy_rain", rain=1.0, wet=1.0, fog=0.3, daylight=0.6, motion_blur_px=4.0
            ),
        ),
        (
            "sun_after_rain",
            Conditions(
                name="sun_after_rain",
                wet=0.8,
                glare=0.6,
                sun_elevation_deg=6.0,
                sun_azimuth_rad=0.1,
            ),
        ),
        ("direct_sunlight", Conditions(name="direct_sunlight", glare=1.0, sun_elevation_deg=4.0)),
        ("tar_seams", Conditions(name="tar_seams", tar_seams=1.0, cracks=0.8)),
        ("randomized", Conditions(randomize=1.0)),
    ],
)
def test_conditions_render_with_consistent_labels(name: str, cond: Conditions) -> None:
    day = render(example_scene("curve", camera=SMALL))
    frame = render(example_scene("curve", camera=SMALL, conditions=cond))
    if name == "tunnel":
        assert (frame.labels[:60] == LEAF_IDS["building_wall_fence"]).mean() > 0.5
        assert frame.corridor.any()
    else:
        # Weather and light change the image, never the labels.
        assert np.array_equal(frame.labels, day.labels)
        assert np.array_equal(frame.corridor, day.corridor)
    assert not np.array_equal(frame.image_bgr, day.image_bgr)
    if name == "night":
        assert frame.image_bgr.mean() < 0.5 * day.image_bgr.mean()


def test_faded_lines_keep_their_labels_but_lose_contrast() -> None:
    scene = example_scene("straight", camera=SMALL, with_objects=False)
    worn = tuple(replace(ln, wear=0.8) for ln in scene.road.lines)
    faded = replace(scene, road=replace(scene.road, lines=worn))
    a, b = render(scene), render(faded)
    assert np.array_equal(a.labels, b.labels)
    mark = a.labels == LEAF_IDS["dividing_white_solid"]
    assert b.image_bgr[mark].mean() < a.image_bgr[mark].mean() - 20


def test_bad_scenes_raise_scenario_errors() -> None:
    scene = example_scene("straight", camera=SMALL)
    with pytest.raises(ScenarioError, match="ego lines"):
        render(replace(scene, ego_left_line=17))
    road = scene.road
    bad = replace(road, x_m=road.x_m[::-1].copy())
    with pytest.raises(ScenarioError, match="increase"):
        render(replace(scene, road=bad))
