"""Camera models from ROS ``sensor_msgs/CameraInfo`` fields found in recordings."""

from __future__ import annotations

from collections.abc import Sequence

from superlane_tools.camera.errors import CameraError
from superlane_tools.camera.model import CameraModel, Extrinsics, Intrinsics

SUPPORTED_DISTORTION_MODELS = ("plumb_bob", "rational_polynomial", "")
"""``distortion_model`` values accepted by :func:`from_camera_info` (empty = none given)."""


def from_camera_info(
    width: int,
    height: int,
    K: Sequence[float],
    D: Sequence[float],
    distortion_model: str,
    extrinsics: Extrinsics,
    name: str = "camera_info",
) -> CameraModel:
    """Build a camera from the fields of a ROS ``CameraInfo`` message.

    Args:
        width: Image width in pixels.
        height: Image height in pixels.
        K: The 3x3 camera matrix, 9 floats, row-major (``fx 0 cx 0 fy cy 0 0 1``), pixels.
        D: Distortion coefficients. ``plumb_bob``: ``k1 k2 p1 p2 k3`` (fewer are padded with
            zeros). ``rational_polynomial``: ``k1 k2 p1 p2 k3 k4 k5 k6``; only the first five are
            kept, which is exact when ``k4 = k5 = k6 = 0`` and an approximation otherwise.
        distortion_model: ``plumb_bob``, ``rational_polynomial`` or empty.
        extrinsics: Camera pose on the vehicle (CameraInfo carries none).
        name: Profile name.

    Raises:
        CameraError: On a wrong K length, skew, non-unit ``K[8]``, or an unsupported model
            (``equidistant`` fisheye and others).
    """
    k = [float(v) for v in K]
    if len(k) != 9:
        raise CameraError(f"CameraInfo K must have 9 values, got {len(k)}")
    fx, skew, cx, _, fy, cy, _, _, k22 = k
    if k22 == 0.0:
        raise CameraError("CameraInfo K is all zero: the camera is uncalibrated")
    if abs(k22 - 1.0) > 1e-9:
        raise CameraError(f"CameraInfo K[8] must be 1, got {k22}")
    if abs(skew) > 1e-6 * max(abs(fx), 1.0):
        raise CameraError(f"CameraInfo K has skew {skew}; skewed pixels are not supported")
    model = distortion_model.strip()
    if model not in SUPPORTED_DISTORTION_MODELS:
        raise CameraError(
            f"unsupported distortion model {distortion_model!r} "
            f"(supported: plumb_bob, rational_polynomial)"
        )
    d = [float(v) for v in D][:5]
    d += [0.0] * (5 - len(d))
    intr = Intrinsics(
        width=int(width),
        height=int(height),
        fx=fx,
        fy=fy,
        cx=cx,
        cy=cy,
        dist=(d[0], d[1], d[2], d[3], d[4]),
    )
    return CameraModel(intrinsics=intr, extrinsics=extrinsics, name=name)
