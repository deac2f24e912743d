"""KITTI calibration parsing (real file) and ROS CameraInfo conversion."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from superlane_tools.camera import (
    CameraError,
    Extrinsics,
    camera_to_yaml,
    from_camera_info,
    kitti_camera,
    load_camera,
    parse_kitti_calib_text,
    read_kitti_calib,
)
from superlane_tools.camera.kitti import camera2_position_in_velo


@pytest.fixture
def calib_path(realdata: Path) -> Path:
    return realdata / "kitti_road" / "calib_um_000000.txt"


def test_real_calib_parses_every_matrix(calib_path: Path) -> None:
    calib = read_kitti_calib(calib_path)
    assert len(calib.projections) == 4
    assert calib.projections[2][0, 0] == pytest.approx(721.5377)
    assert calib.r0_rect.shape == (3, 3)
    assert calib.velo_to_cam.shape == (4, 4)
    assert calib.imu_to_velo is not None
    assert calib.cam_to_road is not None
    np.testing.assert_array_equal(calib.velo_to_cam[3], [0, 0, 0, 1])


def test_camera2_projects_velodyne_points_like_the_kitti_matrices(calib_path: Path) -> None:
    calib = read_kitti_calib(calib_path)
    cam = kitti_camera(calib_path)
    assert (cam.width, cam.height) == (1242, 375)
    assert cam.extrinsics.height_m == 1.65
    rng = np.random.default_rng(0)
    velo = np.stack(
        [rng.uniform(4, 60, 300), rng.uniform(-15, 15, 300), rng.uniform(-1.7, 2, 300)], 1
    )
    rect = np.eye(4)
    rect[:3, :3] = calib.r0_rect
    hom = np.c_[velo, np.ones(len(velo))] @ (calib.projections[2] @ rect @ calib.velo_to_cam).T
    want = hom[:, :2] / hom[:, 2:]
    # vehicle frame = Velodyne axes, origin on the road below camera 2
    vehicle = velo - camera2_position_in_velo(calib) + np.array([0.0, 0.0, 1.65])
    got, front = cam.project(vehicle)
    assert front.all()
    np.testing.assert_allclose(got, want, atol=1e-3)  # the published matrices are rounded


def test_colon_free_and_raw_data_key_styles_give_the_same_camera(calib_path: Path) -> None:
    text = calib_path.read_text(encoding="utf-8")
    colon_free = "\n".join(line.replace(":", "", 1) for line in text.splitlines())
    raw_style = text.replace("P2:", "P_rect_02:").replace("R0_rect:", "R_rect_00:")
    raw_style = "calib_time: 09-Jan-2012 13:57:47\n" + raw_style
    want = kitti_camera(calib_path)
    assert camera_from(colon_free) == want
    assert camera_from(raw_style) == want


def camera_from(text: str):  # type: ignore[no-untyped-def]
    from superlane_tools.camera import camera2_model

    return camera2_model(parse_kitti_calib_text(text))


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("P0: 1 0 0 0 0 1 0 0 0 0 1 0\nTr_velo_to_cam: " + " ".join(["0"] * 12), "no P2"),
        ("P2: 1 2 3\nTr_velo_to_cam: " + " ".join(["0"] * 12), "P2 has 3 values"),
        ("P2: " + " ".join(["1"] * 12), "no Tr_velo_to_cam"),
        ("P2: 1 x 3", "non-numeric"),
    ],
)
def test_malformed_calib_raises(text: str, match: str) -> None:
    with pytest.raises(CameraError, match=match):
        parse_kitti_calib_text(text)


def test_missing_calib_file_raises(tmp_path: Path) -> None:
    with pytest.raises(CameraError, match="cannot read KITTI calibration"):
        read_kitti_calib(tmp_path / "none.txt")


def _fields(obj: object, prefix: str = "") -> dict[str, object]:
    """Flatten a (nested) dataclass into ``{"intrinsics.fx": 721.5, ...}``; tuples by index."""
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        items = [(f.name, getattr(obj, f.name)) for f in dataclasses.fields(obj)]
    elif isinstance(obj, tuple | list):
        items = [(str(i), v) for i, v in enumerate(obj)]
    else:
        return {prefix: obj}
    flat: dict[str, object] = {}
    for name, value in items:
        flat.update(_fields(value, f"{prefix}.{name}" if prefix else name))
    return flat


def test_bundled_kitti_profile_is_current(calib_path: Path) -> None:
    """Regenerate with: slt camera from-kitti <data>/kitti_road/calib_um_000000.txt --out ...

    Floats are compared to 1e-12 (relative): the extrinsics come out of matrix products and
    ``arctan2`` whose last digit differs between numpy/scipy releases.
    """
    bundled, fresh = _fields(load_camera("kitti")), _fields(kitti_camera(calib_path))
    assert bundled.keys() == fresh.keys()
    floats = {k for k, v in fresh.items() if isinstance(v, float)}
    assert floats, "the camera has float fields"
    assert {k: bundled[k] for k in floats} == pytest.approx(
        {k: fresh[k] for k in floats}, rel=1e-12, abs=1e-15
    )
    assert {k: v for k, v in bundled.items() if k not in floats} == {
        k: v for k, v in fresh.items() if k not in floats
    }


def test_camera_info_plumb_bob_and_rational_polynomial() -> None:
    k = [900.0, 0.0, 640.0, 0.0, 905.0, 360.0, 0.0, 0.0, 1.0]
    ext = Extrinsics(height_m=1.4, pitch_rad=0.02)
    cam = from_camera_info(1280, 720, k, [-0.1, 0.01, 0.001, 0.002, 0.0], "plumb_bob", ext)
    assert cam.intrinsics.dist == (-0.1, 0.01, 0.001, 0.002, 0.0)
    assert (cam.intrinsics.fx, cam.intrinsics.fy, cam.intrinsics.cy) == (900.0, 905.0, 360.0)
    assert cam.extrinsics == ext
    rational = from_camera_info(
        1280, 720, k, [-0.1, 0.01, 0.001, 0.002, 0.003, 0.5, 0.1, 0.0], "rational_polynomial", ext
    )
    assert rational.intrinsics.dist == (-0.1, 0.01, 0.001, 0.002, 0.003)
    short = from_camera_info(1280, 720, k, [-0.1], "plumb_bob", ext)
    assert short.intrinsics.dist == (-0.1, 0.0, 0.0, 0.0, 0.0)
    assert not from_camera_info(1280, 720, k, [], "", ext).intrinsics.has_distortion
    assert "fx: 900.0" in camera_to_yaml(cam)


@pytest.mark.parametrize(
    ("k", "model", "match"),
    [
        ([900.0, 0, 640, 0, 900, 360, 0, 0, 1], "equidistant", "unsupported distortion model"),
        ([900.0, 0, 640, 0, 900, 360, 0, 0], "plumb_bob", "9 values"),
        ([0.0] * 9, "plumb_bob", "uncalibrated"),
        ([900.0, 3.0, 640, 0, 900, 360, 0, 0, 1], "plumb_bob", "skew"),
    ],
)
def test_camera_info_rejects_what_the_model_cannot_represent(
    k: list[float], model: str, match: str
) -> None:
    with pytest.raises(CameraError, match=match):
        from_camera_info(1280, 720, k, [0.0] * 5, model, Extrinsics(height_m=1.5))
