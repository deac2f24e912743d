"""Small constructors of ROS 2 messages (rosbags typestore instances) for writers and tests."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

from superlane_tools.recording.typestore import (
    CAN_FRAME_MSGTYPE,
    COMPRESSED_VIDEO_MSGTYPE,
    default_typestore,
)

_NS = 1_000_000_000

_IMAGE_CHANNELS: dict[str, tuple[int, type[np.generic]]] = {
    "mono8": (1, np.uint8),
    "mono16": (1, np.uint16),
    "bgr8": (3, np.uint8),
    "rgb8": (3, np.uint8),
    "bgra8": (4, np.uint8),
    "rgba8": (4, np.uint8),
    "32FC1": (1, np.float32),
}


def _cls(msgtype: str) -> Any:
    return default_typestore().types[msgtype]


def time_msg(stamp_ns: int) -> Any:
    """Return a ``builtin_interfaces/msg/Time`` for ``stamp_ns`` (ns since the epoch)."""
    sec, nanosec = divmod(int(stamp_ns), _NS)
    return _cls("builtin_interfaces/msg/Time")(sec=sec, nanosec=nanosec)


def header(stamp_ns: int, frame_id: str) -> Any:
    """Return a ``std_msgs/msg/Header`` stamped ``stamp_ns`` (ns) in ``frame_id``."""
    return _cls("std_msgs/msg/Header")(stamp=time_msg(stamp_ns), frame_id=frame_id)


def compressed_image(stamp_ns: int, frame_id: str, fmt: str, data: bytes) -> Any:
    """Return a ``sensor_msgs/msg/CompressedImage``.

    Args:
        stamp_ns: Capture time, ns since the epoch.
        frame_id: Camera frame.
        fmt: Image format, e.g. ``jpeg`` or ``png``.
        data: The encoded image bytes.
    """
    return _cls("sensor_msgs/msg/CompressedImage")(
        header=header(stamp_ns, frame_id),
        format=fmt,
        data=np.frombuffer(bytes(data), dtype=np.uint8),
    )


def compressed_video(stamp_ns: int, frame_id: str, fmt: str, data: bytes) -> Any:
    """Return a ``foxglove_msgs/msg/CompressedVideo`` holding one access unit.

    Args:
        stamp_ns: Capture time, ns since the epoch.
        frame_id: Camera frame.
        fmt: Video format: ``h264`` or ``h265`` (Annex B), ``av1``, ``vp9``.
        data: One frame's encoded bytes (a keyframe carries its parameter sets).
    """
    return _cls(COMPRESSED_VIDEO_MSGTYPE)(
        timestamp=time_msg(stamp_ns),
        frame_id=frame_id,
        data=np.frombuffer(bytes(data), dtype=np.uint8),
        format=fmt,
    )


def raw_image(stamp_ns: int, frame_id: str, array: npt.NDArray[Any], encoding: str) -> Any:
    """Return a ``sensor_msgs/msg/Image`` holding ``array`` (rows x cols [x channels]).

    Args:
        stamp_ns: Capture time, ns since the epoch.
        frame_id: Camera frame.
        array: Pixels, shape ``(height, width)`` or ``(height, width, channels)``.
        encoding: ROS image encoding (``mono8``, ``bgr8``, ``rgb8``, ``mono16``, ...).

    Raises:
        ValueError: If the array's shape or dtype does not match ``encoding``.
    """
    channels, dtype = _IMAGE_CHANNELS.get(encoding, (0, np.uint8))
    pixels = np.ascontiguousarray(array)
    if channels:
        shape_channels = 1 if pixels.ndim == 2 else pixels.shape[2]
        if shape_channels != channels or pixels.dtype != dtype:
            raise ValueError(f"{encoding} needs {channels} channel(s) of {np.dtype(dtype).name}")
    height, width = pixels.shape[:2]
    step = pixels.strides[0]
    return _cls("sensor_msgs/msg/Image")(
        header=header(stamp_ns, frame_id),
        height=height,
        width=width,
        encoding=encoding,
        is_bigendian=0,
        step=step,
        data=pixels.view(np.uint8).reshape(-1),
    )


def camera_info(
    stamp_ns: int,
    frame_id: str,
    width: int,
    height: int,
    K: Sequence[float] | npt.NDArray[np.float64],
    D: Sequence[float] | npt.NDArray[np.float64],
    distortion_model: str = "plumb_bob",
) -> Any:
    """Return a ``sensor_msgs/msg/CameraInfo`` (image size in pixels, K as 3x3 or 9 values).

    ``R`` is the identity and ``P`` is ``[K | 0]``, as for a monocular camera.
    """
    k = np.asarray(K, dtype=np.float64).reshape(9)
    p = np.zeros(12, dtype=np.float64)
    p.reshape(3, 4)[:, :3] = k.reshape(3, 3)
    roi = _cls("sensor_msgs/msg/RegionOfInterest")(
        x_offset=0, y_offset=0, height=0, width=0, do_rectify=False
    )
    return _cls("sensor_msgs/msg/CameraInfo")(
        header=header(stamp_ns, frame_id),
        height=height,
        width=width,
        distortion_model=distortion_model,
        d=np.asarray(D, dtype=np.float64).reshape(-1),
        k=k,
        r=np.eye(3, dtype=np.float64).reshape(9),
        p=p,
        binning_x=0,
        binning_y=0,
        roi=roi,
    )


def can_frame(stamp_ns: int, can_id: int, data: bytes, is_extended: bool = False) -> Any:
    """Return a ``can_msgs/msg/Frame`` (classic CAN, up to 8 data bytes, zero-padded)."""
    payload = bytes(data)
    if len(payload) > 8:
        raise ValueError(f"a classic CAN frame holds at most 8 bytes, got {len(payload)}")
    padded = np.zeros(8, dtype=np.uint8)
    padded[: len(payload)] = np.frombuffer(payload, dtype=np.uint8)
    return _cls(CAN_FRAME_MSGTYPE)(
        header=header(stamp_ns, ""),
        id=int(can_id),
        is_rtr=False,
        is_extended=bool(is_extended),
        is_error=False,
        dlc=len(payload),
        data=padded,
    )


def navsatfix(
    stamp_ns: int,
    frame_id: str,
    lat_deg: float,
    lon_deg: float,
    alt_m: float,
    status: int = 0,
    covariance_enu_m2: Sequence[float] | npt.NDArray[np.float64] | None = None,
) -> Any:
    """Return a ``sensor_msgs/msg/NavSatFix``.

    Args:
        stamp_ns: Fix time, ns since the epoch.
        frame_id: Antenna frame.
        lat_deg: Latitude, degrees (WGS84).
        lon_deg: Longitude, degrees (WGS84).
        alt_m: Altitude above the WGS84 ellipsoid, metres.
        status: ``NavSatStatus.status`` (-1 no fix, 0 fix, 1 SBAS, 2 GBAS/RTK).
        covariance_enu_m2: Position covariance, 3x3 or 9 values in m^2, ENU; None: unknown.
    """
    known = covariance_enu_m2 is not None
    cov = (
        np.asarray(covariance_enu_m2, dtype=np.float64).reshape(9)
        if known
        else np.zeros(9, dtype=np.float64)
    )
    nav_status = _cls("sensor_msgs/msg/NavSatStatus")(status=int(status), service=1)
    return _cls("sensor_msgs/msg/NavSatFix")(
        header=header(stamp_ns, frame_id),
        status=nav_status,
        latitude=float(lat_deg),
        longitude=float(lon_deg),
        altitude=float(alt_m),
        position_covariance=cov,
        position_covariance_type=3 if known else 0,
    )


def tf_static(
    stamp_ns: int,
    parent: str,
    child: str,
    translation: Sequence[float],
    quaternion_xyzw: Sequence[float],
) -> Any:
    """Return a ``tf2_msgs/msg/TFMessage`` with one transform ``parent`` -> ``child``.

    Args:
        stamp_ns: Stamp, ns since the epoch.
        parent: Parent frame id.
        child: Child frame id.
        translation: x, y, z of the child origin in the parent frame, metres.
        quaternion_xyzw: Rotation of the child frame in the parent frame, (x, y, z, w).
    """
    tx, ty, tz = (float(v) for v in translation)
    qx, qy, qz, qw = (float(v) for v in quaternion_xyzw)
    transform = _cls("geometry_msgs/msg/Transform")(
        translation=_cls("geometry_msgs/msg/Vector3")(x=tx, y=ty, z=tz),
        rotation=_cls("geometry_msgs/msg/Quaternion")(x=qx, y=qy, z=qz, w=qw),
    )
    stamped = _cls("geometry_msgs/msg/TransformStamped")(
        header=header(stamp_ns, parent), child_frame_id=child, transform=transform
    )
    return _cls("tf2_msgs/msg/TFMessage")(transforms=[stamped])


def imu(
    stamp_ns: int,
    frame_id: str,
    angular_velocity_rps: Sequence[float] | npt.NDArray[np.float64],
    linear_acceleration_mps2: Sequence[float] | npt.NDArray[np.float64] | None = None,
) -> Any:
    """Return a ``sensor_msgs/msg/Imu`` without orientation (covariance[0] = -1).

    Args:
        stamp_ns: Sample time, ns since the epoch.
        frame_id: IMU frame.
        angular_velocity_rps: Gyro x, y, z in the IMU frame, rad/s.
        linear_acceleration_mps2: Accelerometer x, y, z, m/s^2; None: zeros (unknown: its
            covariance[0] is -1).
    """
    vec = _cls("geometry_msgs/msg/Vector3")
    gyro = [float(v) for v in angular_velocity_rps]
    accel = [0.0, 0.0, 0.0] if linear_acceleration_mps2 is None else list(linear_acceleration_mps2)
    unknown = np.zeros(9, dtype=np.float64)
    unknown[0] = -1.0
    accel_cov = unknown.copy() if linear_acceleration_mps2 is None else np.zeros(9)
    return _cls("sensor_msgs/msg/Imu")(
        header=header(stamp_ns, frame_id),
        orientation=_cls("geometry_msgs/msg/Quaternion")(x=0.0, y=0.0, z=0.0, w=1.0),
        orientation_covariance=unknown,
        angular_velocity=vec(x=gyro[0], y=gyro[1], z=gyro[2]),
        angular_velocity_covariance=np.zeros(9, dtype=np.float64),
        linear_acceleration=vec(x=float(accel[0]), y=float(accel[1]), z=float(accel[2])),
        linear_acceleration_covariance=accel_cov,
    )
