"""The ``slt_camera`` metadata record: the one codec of a camera in a recording's metadata.

``slt simulate`` writes it into MCAP files; reprocess reads the extrinsics back from it. The
same module converts a ``/tf_static`` vehicle -> camera-optical transform into extrinsics.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from superlane_tools.camera.model import CameraModel, Extrinsics

METADATA_NAME = "slt_camera"
"""Name of the MCAP metadata record holding the camera (keys: :func:`camera_metadata`)."""


def camera_quaternion_xyzw(camera: CameraModel) -> tuple[float, float, float, float]:
    """Return the rotation of the camera optical frame in the vehicle frame as ``(x, y, z, w)``."""
    from scipy.spatial.transform import Rotation

    q = Rotation.from_matrix(camera.extrinsics.rotation).as_quat()
    return (float(q[0]), float(q[1]), float(q[2]), float(q[3]))


def camera_metadata(camera: CameraModel, parent: str, child: str) -> dict[str, str]:
    """Return the MCAP metadata record ``slt_camera`` describing the camera (string values).

    Keys: ``name``, ``parent_frame``, ``child_frame``, ``width``, ``height``, ``fx``, ``fy``,
    ``cx``, ``cy``, ``dist`` (comma-separated k1,k2,p1,p2,k3), ``height_m``, ``pitch_rad``,
    ``roll_rad``, ``yaw_rad``, ``x_m``, ``y_m`` (angles as in ``camera/model.py``),
    ``translation_m`` and ``quaternion_xyzw`` (comma-separated, as in ``/tf_static``).
    """
    k, e = camera.intrinsics, camera.extrinsics
    q = camera_quaternion_xyzw(camera)
    return {
        "name": camera.name,
        "parent_frame": parent,
        "child_frame": child,
        "width": str(k.width),
        "height": str(k.height),
        "fx": repr(k.fx),
        "fy": repr(k.fy),
        "cx": repr(k.cx),
        "cy": repr(k.cy),
        "dist": ",".join(repr(float(d)) for d in k.dist),
        "height_m": repr(e.height_m),
        "pitch_rad": repr(e.pitch_rad),
        "roll_rad": repr(e.roll_rad),
        "yaw_rad": repr(e.yaw_rad),
        "x_m": repr(e.x_m),
        "y_m": repr(e.y_m),
        "translation_m": ",".join(repr(float(v)) for v in e.position),
        "quaternion_xyzw": ",".join(repr(v) for v in q),
    }


def extrinsics_from_metadata(record: Mapping[str, str]) -> Extrinsics:
    """Return the extrinsics stored in an ``slt_camera`` record (see :func:`camera_metadata`).

    Raises:
        KeyError: If ``height_m`` is missing.
        ValueError: If a value is not a number.
    """
    return Extrinsics(
        height_m=float(record["height_m"]),
        pitch_rad=float(record.get("pitch_rad", 0.0)),
        roll_rad=float(record.get("roll_rad", 0.0)),
        yaw_rad=float(record.get("yaw_rad", 0.0)),
        x_m=float(record.get("x_m", 0.0)),
        y_m=float(record.get("y_m", 0.0)),
    )


_BASE = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])


def extrinsics_from_tf(
    translation: Sequence[float], quaternion_xyzw: Sequence[float]
) -> Extrinsics:
    """Convert a vehicle -> camera-optical transform into :class:`Extrinsics` angles.

    The transform's rotation maps optical-frame vectors into the vehicle frame; removing the
    fixed optical-axis permutation leaves ``Rz(yaw) Ry(pitch) Rx(roll)`` (see ``camera/model.py``).
    """
    from scipy.spatial.transform import Rotation

    full = Rotation.from_quat(list(quaternion_xyzw)).as_matrix()
    yaw, pitch, roll = Rotation.from_matrix(full @ _BASE.T).as_euler("ZYX")
    x, y, z = (float(v) for v in translation)
    return Extrinsics(
        height_m=z, pitch_rad=float(pitch), roll_rad=float(roll), yaw_rad=float(yaw), x_m=x, y_m=y
    )
