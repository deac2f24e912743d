"""KITTI calibration files: parse ``P0..P3``, ``R0_rect``, ``Tr_*`` and build the camera-2 model.

KITTI object/road calibration files hold one matrix per line, ``KEY: v1 v2 ...`` (``P2:``,
``R0_rect:``, ``Tr_velo_to_cam:``, ``Tr_imu_to_velo:``, ``Tr_cam_to_road:``); the raw-data
files write ``KEY: values`` with other names (``P_rect_02``, ``R_rect_00``) and a few tools write
``KEY values`` without the colon. All are accepted.

Camera 2 (left colour camera) in this package's conventions:

* Intrinsics from ``P2 = K2 [I | t2]`` (rectified images, no distortion).
* Orientation from ``R0_rect @ Tr_velo_to_cam``: the Velodyne frame is ``x`` forward, ``y`` left,
  ``z`` up, i.e. the vehicle frame's axes; its rotation to the camera gives pitch, roll and yaw.
* Height: the documented KITTI camera mount height, 1.65 m above the road
  (Geiger et al., IJRR 2013), because the calibration says nothing about the ground.
* The vehicle-frame origin is on the road directly below camera 2 (``x_m = y_m = 0``), so
  lateral offsets are measured from the camera.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from superlane_tools.camera.errors import CameraError
from superlane_tools.camera.model import _BASE, CameraModel, Extrinsics, FloatArray, Intrinsics

KITTI_CAMERA_HEIGHT_M = 1.65
"""Height of the KITTI cameras above the road, metres (Geiger et al., IJRR 2013)."""
KITTI_ROAD_IMAGE_SIZE = (1242, 375)
"""Width and height in pixels of the KITTI road benchmark images."""

_ALIASES = {
    "P_rect_00": "P0",
    "P_rect_01": "P1",
    "P_rect_02": "P2",
    "P_rect_03": "P3",
    "R_rect_00": "R0_rect",
    "R_rect": "R0_rect",
    "R0": "R0_rect",
    "Tr_velo_cam": "Tr_velo_to_cam",
    "Tr_imu_velo": "Tr_imu_to_velo",
}
_SHAPES = {"P": (3, 4), "R0_rect": (3, 3), "Tr": (3, 4)}


@dataclass(frozen=True)
class KittiCalib:
    """The matrices of a KITTI calibration file.

    Attributes:
        projections: ``P0..P3`` (3x4) projection matrices of the rectified cameras, pixels.
        r0_rect: 3x3 rectifying rotation of the reference camera.
        velo_to_cam: 4x4 Velodyne -> reference camera transform (metres).
        imu_to_velo: 4x4 IMU -> Velodyne transform (metres), if present.
        cam_to_road: 4x4 rectified camera -> road transform (KITTI road only), if present.
    """

    projections: tuple[FloatArray, ...]
    r0_rect: FloatArray
    velo_to_cam: FloatArray
    imu_to_velo: FloatArray | None = None
    cam_to_road: FloatArray | None = None


def _homogeneous(m: FloatArray) -> FloatArray:
    out = np.eye(4)
    out[: m.shape[0], : m.shape[1]] = m
    return out


def parse_kitti_calib_text(text: str, source: str = "<calib>") -> KittiCalib:
    """Parse the text of a KITTI calibration file.

    Raises:
        CameraError: If a needed matrix is missing or has the wrong number of values.
    """
    values: dict[str, FloatArray] = {}
    for number, raw in enumerate(text.splitlines(), start=1):
        line = raw.strip()
        if not line or line.startswith("#"):
            continue
        if ":" in line:
            key, _, rest = line.partition(":")
        else:
            key, _, rest = line.partition(" ")
        key = _ALIASES.get(key.strip(), key.strip())
        try:
            nums = np.array([float(v) for v in rest.split()], dtype=np.float64)
        except ValueError:
            if key.startswith(("P", "R0", "Tr")):
                raise CameraError(f"{source}:{number}: non-numeric value in {key}") from None
            continue  # e.g. "calib_time: 09-Jan-2012 ..."
        values[key] = nums

    def matrix(key: str, required: bool = True) -> FloatArray | None:
        if key not in values:
            if required:
                raise CameraError(f"{source}: no {key} in the calibration file")
            return None
        shape = _SHAPES["P" if key.startswith("P") else key if key == "R0_rect" else "Tr"]
        nums = values[key]
        if key.startswith("Tr") and nums.size == 16:
            return nums.reshape(4, 4)
        if nums.size != shape[0] * shape[1]:
            raise CameraError(
                f"{source}: {key} has {nums.size} values, expected {shape[0] * shape[1]}"
            )
        return _homogeneous(nums.reshape(shape)) if key.startswith("Tr") else nums.reshape(shape)

    projections = tuple(m for k in ("P0", "P1", "P2", "P3") if (m := matrix(k, False)) is not None)
    if "P2" not in values:
        raise CameraError(f"{source}: no P2 in the calibration file")
    r0 = matrix("R0_rect", required=False)
    velo = matrix("Tr_velo_to_cam")
    assert velo is not None  # required=True raised otherwise
    return KittiCalib(
        projections=projections,
        r0_rect=np.eye(3) if r0 is None else r0,
        velo_to_cam=velo,
        imu_to_velo=matrix("Tr_imu_to_velo", required=False),
        cam_to_road=matrix("Tr_cam_to_road", required=False),
    )


def read_kitti_calib(path: str | os.PathLike[str]) -> KittiCalib:
    """Read and parse a KITTI calibration file.

    Raises:
        CameraError: If the file cannot be read or is malformed.
    """
    file = Path(path)
    try:
        text = file.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as err:
        reason = err.strerror if isinstance(err, OSError) else "not UTF-8 text"
        raise CameraError(f"cannot read KITTI calibration {file}: {reason}") from err
    return parse_kitti_calib_text(text, source=str(file))


def velo_to_camera2(calib: KittiCalib) -> FloatArray:
    """Return the 4x4 transform from Velodyne points (m) to camera-2 optical coordinates (m)."""
    p2 = calib.projections[2] if len(calib.projections) > 2 else None
    if p2 is None:
        raise CameraError("calibration has no P2")
    k = p2[:, :3]
    t2 = np.linalg.solve(k, p2[:, 3])  # camera-2 offset from the rectified reference camera
    rect = _homogeneous(calib.r0_rect)
    shift = np.eye(4)
    shift[:3, 3] = t2
    out: FloatArray = shift @ rect @ calib.velo_to_cam
    return out


def _angles(rot_cam_to_vehicle: FloatArray) -> tuple[float, float, float]:
    """Return (pitch, roll, yaw) in radians such that Rz(yaw) Ry(pitch) Rx(roll) BASE = R."""
    m = rot_cam_to_vehicle @ _BASE.T
    pitch = math.asin(max(-1.0, min(1.0, -float(m[2, 0]))))
    roll = math.atan2(float(m[2, 1]), float(m[2, 2]))
    yaw = math.atan2(float(m[1, 0]), float(m[0, 0]))
    return pitch, roll, yaw


def camera2_model(
    calib: KittiCalib,
    width: int = KITTI_ROAD_IMAGE_SIZE[0],
    height: int = KITTI_ROAD_IMAGE_SIZE[1],
    camera_height_m: float = KITTI_CAMERA_HEIGHT_M,
    name: str = "kitti",
) -> CameraModel:
    """Build the :class:`CameraModel` of KITTI camera 2 from its calibration.

    Args:
        calib: Parsed calibration.
        width: Image width in pixels (KITTI road: 1242; raw sequences vary slightly).
        height: Image height in pixels (KITTI road: 375).
        camera_height_m: Camera height above the road, metres.
        name: Profile name.
    """
    p2 = calib.projections[2]
    intr = Intrinsics(
        width=width,
        height=height,
        fx=float(p2[0, 0]),
        fy=float(p2[1, 1]),
        cx=float(p2[0, 2]),
        cy=float(p2[1, 2]),
    )
    tf = velo_to_camera2(calib)
    # Columns of the inverse rotation are the camera axes in the Velodyne (vehicle) frame;
    # re-orthonormalise because the published matrices are rounded.
    u, _, vt = np.linalg.svd(tf[:3, :3].T)
    pitch, roll, yaw = _angles(u @ vt)
    extr = Extrinsics(height_m=camera_height_m, pitch_rad=pitch, roll_rad=roll, yaw_rad=yaw)
    return CameraModel(intrinsics=intr, extrinsics=extr, name=name)


def camera2_position_in_velo(calib: KittiCalib) -> FloatArray:
    """Return the optical centre of camera 2 in the Velodyne frame, metres."""
    inv = np.linalg.inv(velo_to_camera2(calib))
    return np.asarray(inv[:3, 3], dtype=np.float64)


def kitti_camera(
    path: str | os.PathLike[str],
    width: int = KITTI_ROAD_IMAGE_SIZE[0],
    height: int = KITTI_ROAD_IMAGE_SIZE[1],
    camera_height_m: float = KITTI_CAMERA_HEIGHT_M,
    name: str = "kitti",
) -> CameraModel:
    """Read a KITTI calibration file and return the camera-2 model (see :func:`camera2_model`)."""
    return camera2_model(read_kitti_calib(path), width, height, camera_height_m, name)
