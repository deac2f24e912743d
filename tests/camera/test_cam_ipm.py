"""Bird's-eye-view grid and image warping."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from superlane_tools.camera import (
    BevGrid,
    CameraError,
    bev_maps,
    ground_to_image,
    load_camera,
    warp_to_bev,
)


def test_grid_shape_centres_and_pixels() -> None:
    grid = BevGrid(x_min_m=5.0, x_max_m=45.0, y_min_m=-8.0, y_max_m=8.0, resolution_m=0.2)
    assert grid.shape == (200, 80)
    xs, ys = grid.x_centers(), grid.y_centers()
    assert xs[0] == pytest.approx(44.9)
    assert xs[-1] == pytest.approx(5.1)
    assert ys[0] == pytest.approx(7.9)
    assert ys[-1] == pytest.approx(-7.9)
    col, row = grid.to_pixel(np.array([xs[10]]), np.array([ys[3]]))
    assert (col[0], row[0]) == pytest.approx((3.0, 10.0))
    assert grid.extent() == (8.0, -8.0, 5.0, 45.0)


@pytest.mark.parametrize(
    "kwargs",
    [{"resolution_m": 0.0}, {"x_min_m": 10.0, "x_max_m": 5.0}, {"y_min_m": 1.0, "y_max_m": 1.0}],
)
def test_bad_grids_raise(kwargs: dict[str, float]) -> None:
    with pytest.raises(CameraError):
        BevGrid(**kwargs)


def test_warp_samples_the_pixel_each_cell_projects_to() -> None:
    cam = load_camera("sim_default")
    # an image whose value is its own column (u) and row (v) in two float channels
    v, u = np.mgrid[0 : cam.height, 0 : cam.width].astype(np.float32)
    image = np.dstack([u, v])
    grid = BevGrid(x_min_m=6.0, x_max_m=40.0, y_min_m=-6.0, y_max_m=6.0, resolution_m=0.5)
    bev = warp_to_bev(cam, image, grid)
    assert bev.shape == (*grid.shape, 2)
    xs, ys = np.meshgrid(grid.x_centers(), grid.y_centers(), indexing="ij")
    want = ground_to_image(cam, xs, ys).reshape(*grid.shape, 2)
    inside = (
        (want[..., 0] >= 0) & (want[..., 0] <= cam.width - 1) & (want[..., 1] <= cam.height - 1)
    )
    assert 0.3 < inside.mean() < 1.0
    # cv2.remap interpolates with 1/32-pixel fixed-point weights
    np.testing.assert_allclose(bev[inside], want[inside], atol=0.02)
    assert (bev[~inside] == 0).all()
    map_u, map_v = bev_maps(cam, grid)
    np.testing.assert_allclose(map_u, want[..., 0])
    np.testing.assert_allclose(map_v, want[..., 1])


def test_warp_outside_the_image_is_zero_and_nearest_keeps_labels() -> None:
    cam = load_camera("sim_default")
    labels = np.full((cam.height, cam.width), 7, dtype=np.uint8)
    grid = BevGrid(x_min_m=-5.0, x_max_m=20.0, y_min_m=-60.0, y_max_m=60.0, resolution_m=1.0)
    bev = warp_to_bev(cam, labels, grid, interpolation="nearest")
    assert set(np.unique(bev).tolist()) == {0, 7}
    rows_behind = grid.x_centers() < 0
    assert (bev[rows_behind] == 0).all()


def test_warp_checks_image_size_and_interpolation() -> None:
    cam = load_camera("sim_default")
    with pytest.raises(CameraError, match="image is 10x10"):
        warp_to_bev(cam, np.zeros((10, 10), np.uint8), BevGrid())
    with pytest.raises(CameraError, match="interpolation"):
        warp_to_bev(cam, np.zeros((720, 1280), np.uint8), BevGrid(), interpolation="cubic")


def test_tusimple_labels_are_near_parallel_in_the_bev_of_the_tusimple_profile(
    realdata: Path,
) -> None:
    """With the estimated camera, labelled lanes of a real frame map to near-parallel lines."""
    from superlane_tools.camera import image_to_ground
    from superlane_tools.evaluation import load_jsonl

    cam = load_camera("tusimple")
    rec = load_jsonl(realdata / "tusimple" / "frames" / "labels.json")[0]
    headings = []
    widths = []
    for lane in rec.lanes:
        x_img = np.asarray(lane)
        ok = x_img >= 0
        uv = np.stack([x_img[ok], np.asarray(rec.h_samples)[ok]], axis=1)
        x, y, valid = image_to_ground(cam, uv)
        near = valid & (x < 40.0)
        slope, offset = np.polyfit(x[near], y[near], 1)
        headings.append(slope)
        widths.append(offset)
    assert np.ptp(headings) < 0.05  # radians-ish: lanes within ~3 degrees of each other
    gaps = np.diff(np.sort(widths))
    assert np.all((gaps > 2.8) & (gaps < 4.8))
