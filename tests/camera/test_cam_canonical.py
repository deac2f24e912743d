"""The canonical virtual camera with real cameras (KITTI calibration file, TuSimple profile)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from superlane_tools.camera import CameraError, CameraModel, kitti_camera, load_camera
from superlane_tools.camera.canonical import (
    CanonicalCamera,
    CanonicalMaps,
    canonical_maps,
    source_to_canonical,
)

CANONICAL = CanonicalCamera()


def _kitti(realdata: Path) -> CameraModel:
    return kitti_camera(realdata / "kitti_road" / "calib_um_000000.txt").resized(640, 193)


def _tusimple() -> CameraModel:
    return load_camera("tusimple").resized(640, 360)


def _distorted() -> CameraModel:
    """The TuSimple camera behind a barrel-distorting lens (the distortion path of the map)."""
    cam = _tusimple()
    lens = dataclasses.replace(cam.intrinsics, dist=(-0.28, 0.09, 0.0005, -0.0004, -0.012))
    return dataclasses.replace(cam, intrinsics=lens)


def _rotated() -> CameraModel:
    """The TuSimple camera rolled by 3 degrees and yawed by 2 (besides its 0.12 rad pitch)."""
    cam = _tusimple()
    pose = dataclasses.replace(cam.extrinsics, roll_rad=0.052, yaw_rad=0.035)
    return dataclasses.replace(cam, extrinsics=pose)


@pytest.fixture(params=["kitti", "tusimple", "distorted", "rotated"])
def drive(request: pytest.FixtureRequest, realdata: Path) -> CameraModel:
    makers = {"tusimple": _tusimple, "distorted": _distorted, "rotated": _rotated}
    return _kitti(realdata) if request.param == "kitti" else makers[request.param]()


def _bilinear(grid: np.ndarray, uv: np.ndarray) -> np.ndarray:
    u0, v0 = np.floor(uv[:, 0]).astype(int), np.floor(uv[:, 1]).astype(int)
    fu, fv = uv[:, 0] - u0, uv[:, 1] - v0
    g = grid.astype(np.float64)
    top = g[v0, u0] * (1 - fu) + g[v0, u0 + 1] * fu
    bottom = g[v0 + 1, u0] * (1 - fu) + g[v0 + 1, u0 + 1] * fu
    out: np.ndarray = top * (1 - fv) + bottom * fv
    return out


def _ground_points() -> np.ndarray:
    xs, ys = np.meshgrid(np.linspace(7.0, 60.0, 12), np.linspace(-3.5, 3.5, 8))
    return np.stack([xs.ravel(), ys.ravel(), np.zeros(xs.size)], axis=1)


def test_ground_point_through_the_forward_map_lands_where_the_canonical_camera_sees_it(
    drive: CameraModel,
) -> None:
    maps = canonical_maps(drive, CANONICAL)
    points = _ground_points()
    canon_uv, front = maps.canonical.project(points)
    source_uv, _ = drive.project(points)
    inside = (
        front
        & (canon_uv[:, 0] > 0)
        & (canon_uv[:, 0] < CANONICAL.width - 2)
        & (canon_uv[:, 1] > 0)
        & (canon_uv[:, 1] < CANONICAL.height - 2)
    )
    assert inside.sum() >= 40  # most of the 5-60 m band is in view
    mapped = np.stack(
        [_bilinear(maps.forward_x, canon_uv[inside]), _bilinear(maps.forward_y, canon_uv[inside])],
        axis=1,
    )
    np.testing.assert_allclose(mapped, source_uv[inside], atol=0.05)
    # and back: the exact inverse mapping takes the source pixels to the canonical ones
    back = source_to_canonical(drive, maps.canonical, source_uv[inside])
    np.testing.assert_allclose(back, canon_uv[inside], atol=1e-6)


def test_the_canonical_camera_is_level_and_keeps_the_drive_centre_and_yaw(
    drive: CameraModel,
) -> None:
    model = CANONICAL.model(drive)
    assert model.extrinsics.pitch_rad == 0.0
    assert model.extrinsics.roll_rad == 0.0
    assert model.extrinsics.yaw_rad == drive.extrinsics.yaw_rad
    np.testing.assert_array_equal(model.extrinsics.position, drive.extrinsics.position)
    assert model.horizon_row() == CANONICAL.horizon_row
    assert not model.intrinsics.has_distortion


def test_a_rotated_cameras_horizon_lands_on_the_canonical_row() -> None:
    drive = _rotated()
    maps = canonical_maps(drive, CANONICAL)
    far = np.stack(
        [np.full(9, 1e5), np.linspace(-4e4, 4e4, 9), np.zeros(9)], axis=1
    )  # flat-road points 100 km ahead: on the horizon
    source_uv, front = drive.project(far)
    assert front.all()
    assert np.ptp(source_uv[:, 1]) > 10.0  # the source horizon is tilted (roll) and not on a row
    canon = source_to_canonical(drive, maps.canonical, source_uv)
    np.testing.assert_allclose(canon[:, 1], CANONICAL.horizon_row, atol=0.02)
    # the forward map's horizon row holds the source pixels whose rays are level
    row = int(CANONICAL.horizon_row)
    cols = np.arange(20, CANONICAL.width - 20, 40)
    uv = np.stack([maps.forward_x[row, cols], maps.forward_y[row, cols]], axis=1)
    assert (uv >= 0).all()
    np.testing.assert_allclose(drive.rays(uv.astype(np.float64))[:, 2], 0.0, atol=2e-4)


def _kitti_labels(realdata: Path, name: str) -> np.ndarray:
    import cv2

    gt = cv2.imread(str(realdata / "kitti_road" / name), cv2.IMREAD_COLOR)
    ids = (gt[:, :, 0] > 127).astype(np.uint8) + 2 * (gt[:, :, 2] > 127).astype(np.uint8)
    return np.asarray(cv2.resize(ids, (640, 193), interpolation=cv2.INTER_NEAREST), np.uint8)


@pytest.mark.parametrize("name", ["gt_um_road_000000.png", "gt_um_lane_000000.png"])
def test_forward_then_back_is_the_identity_on_the_covered_region(realdata: Path, name: str) -> None:
    labels = _kitti_labels(realdata, name)
    assert len(np.unique(labels)) >= 2
    maps = canonical_maps(_kitti(realdata), CANONICAL)
    canon = maps.to_canonical(labels, nearest=True)
    assert canon.shape == (CANONICAL.height, CANONICAL.width)
    back = maps.labels_to_source(canon)
    covered = maps.covered()
    assert covered.mean() > 0.3
    same = (back == labels)[covered].mean()
    assert same >= 0.99, same
    assert (back[~covered] == 0).all()  # what the canonical camera does not see is void


def test_the_forward_map_undistorts(realdata: Path) -> None:
    """A straight road edge, curved by the lens in the source image, is straight again."""
    drive = _distorted()
    maps = canonical_maps(drive, CANONICAL)
    edge = np.stack([np.linspace(8.0, 50.0, 30), np.full(30, 4.0), np.zeros(30)], axis=1)
    canon_uv, _ = maps.canonical.project(edge)
    # the canonical image of a 3D line is a line: collinear to float precision
    d = canon_uv - canon_uv[0]
    cross = d[:, 0] * d[-1, 1] - d[:, 1] * d[-1, 0]
    assert np.abs(cross).max() / np.linalg.norm(d[-1]) < 1e-6
    source_uv, _ = drive.project(edge)
    ds = source_uv - source_uv[0]
    bend = np.abs(ds[:, 0] * ds[-1, 1] - ds[:, 1] * ds[-1, 0]).max() / np.linalg.norm(ds[-1])
    assert bend > 0.3  # the lens bends it in the recording
    mapped = np.stack(
        [_bilinear(maps.forward_x, canon_uv), _bilinear(maps.forward_y, canon_uv)], axis=1
    )
    np.testing.assert_allclose(mapped, source_uv, atol=0.05)


def test_sizes_and_errors() -> None:
    band = CanonicalCamera.for_input(512, 160)
    assert band == CANONICAL
    tall = CanonicalCamera.for_input(512, 288)
    assert tall.focal_px == 400.0
    assert tall.horizon_row == 152.0
    assert CANONICAL.near_range_m(1.7) == pytest.approx(5.04, abs=0.01)
    assert CanonicalCamera.from_dict(tall.to_dict()) == tall
    near = CanonicalCamera.for_input(512, 224, near_range_m=3.4)  # the near field kept
    assert near.focal_px == 400.0
    assert near.horizon_row == pytest.approx(23.0)
    assert near.near_range_m(1.7) == pytest.approx(3.4)
    assert CanonicalCamera.for_input(512, 160, near_range_m=None) == CANONICAL
    with pytest.raises(CameraError, match="near range"):
        CanonicalCamera.for_input(512, 224, near_range_m=0.0)
    with pytest.raises(CameraError, match="horizon"):
        CanonicalCamera(512, 160, 400.0, 200.0)
    with pytest.raises(CameraError, match="invalid canonical camera"):
        CanonicalCamera.from_dict({"width": 512})
    maps = canonical_maps(_tusimple(), CANONICAL)
    assert isinstance(maps, CanonicalMaps)
    with pytest.raises(CameraError, match="the map expects 640x360"):
        maps.to_canonical(np.zeros((10, 10, 3), np.uint8))
    looking_up = dataclasses.replace(
        _tusimple(), extrinsics=dataclasses.replace(_tusimple().extrinsics, pitch_rad=-1.2)
    )
    with pytest.raises(CameraError, match="sees nothing"):
        canonical_maps(looking_up, CANONICAL)
