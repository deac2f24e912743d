"""Inputs of a reprocess run: stream selection, the camera model, and frame decoding."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from superlane_tools.camera.model import CameraModel, Extrinsics
from superlane_tools.errors import UsageError
from superlane_tools.pipeline._images import (
    MIN_FRAME_SIDE,
    imdecode,
    jpeg_size,
    raw_pixels,
    sniff_format,
)
from superlane_tools.pipeline.extract import ExtractConfig, select_streams
from superlane_tools.pipeline.reprocess.config import ReprocessConfig
from superlane_tools.recording.base import Recording, field_value
from superlane_tools.records import Message, TopicInfo

TF_TYPES = frozenset({"tf2_msgs/msg/TFMessage"})
RAW_TYPES = frozenset({"sensor_msgs/msg/Image", "foxglove.RawImage"})
METADATA_NAME = "slt_camera"
"""MCAP metadata record with the camera extrinsics (written by ``slt simulate``)."""


class Streams(NamedTuple):
    """The topic of each stream ("" when the recording has none)."""

    frames: str
    camera_info: str
    can: str
    gnss: str
    tf: str
    notes: tuple[str, ...]


def select(topics: Sequence[TopicInfo], config: ReprocessConfig) -> Streams:
    """Pick one topic per stream, from the config or by message type.

    Raises:
        UsageError: If a configured topic is missing from the recording.
    """
    wanted = {
        kind: (topic,)
        for kind, topic in (
            ("frames", config.topics.frames),
            ("camera_info", config.topics.camera_info),
            ("can", config.topics.can),
            ("gnss", config.topics.gnss),
        )
        if topic
    }
    selected = select_streams(topics, ExtractConfig(streams=wanted))
    notes = []
    picked: dict[str, str] = {}
    for kind in ("frames", "camera_info", "can", "gnss"):
        found = selected.get(kind, ())
        picked[kind] = found[0] if found else ""
        if len(found) > 1:
            notes.append(f"several {kind} topics ({', '.join(found)}): using {found[0]}")
    tf = next((t.topic for t in topics if t.msgtype in TF_TYPES), "")
    return Streams(
        picked["frames"], picked["camera_info"], picked["can"], picked["gnss"], tf, tuple(notes)
    )


def _sequence(value: Any) -> list[Any]:
    """Return a message's array field as a list (None -> []); rosbags gives numpy arrays."""
    return [] if value is None else list(value)


def _mcap_extrinsics(path: Path) -> Extrinsics | None:
    if path.suffix.lower() != ".mcap" or not path.is_file():
        return None
    from mcap.reader import make_reader

    try:
        with path.open("rb") as handle:
            for record in make_reader(handle).iter_metadata():
                if record.name == METADATA_NAME:
                    m = record.metadata
                    return Extrinsics(
                        height_m=float(m["height_m"]),
                        pitch_rad=float(m.get("pitch_rad", 0.0)),
                        roll_rad=float(m.get("roll_rad", 0.0)),
                        yaw_rad=float(m.get("yaw_rad", 0.0)),
                        x_m=float(m.get("x_m", 0.0)),
                        y_m=float(m.get("y_m", 0.0)),
                    )
    except Exception:  # a damaged summary or odd metadata: fall back to /tf_static
        return None
    return None


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


def _tf_extrinsics(rec: Recording, topic: str, frame_id: str) -> Extrinsics | None:
    if not topic:
        return None
    for msg in rec.messages(topics=[topic]):
        for tr in _sequence(field_value(msg.data, "transforms")):
            child = str(field_value(tr, "child_frame_id") or "")
            if frame_id and child.strip("/") != frame_id.strip("/"):
                continue
            t = tr.transform.translation
            q = tr.transform.rotation
            return extrinsics_from_tf((t.x, t.y, t.z), (q.x, q.y, q.z, q.w))
    return None


def resolve_camera(
    rec: Recording, path: Path, streams: Streams, camera: str
) -> tuple[CameraModel, str]:
    """Return the camera and a sentence saying where it came from.

    ``auto`` takes the intrinsics from the first CameraInfo and the extrinsics from the MCAP
    ``slt_camera`` metadata record or from ``/tf_static``; anything else is a profile name or
    a camera YAML file.

    Raises:
        UsageError: If ``auto`` finds no calibration or no extrinsics.
        CameraError: If a profile or the CameraInfo is invalid.
    """
    from superlane_tools.camera.profiles import load_camera
    from superlane_tools.camera.ros import from_camera_info

    if camera != "auto":
        return load_camera(camera), f"camera profile {camera}"
    if not streams.camera_info:
        raise UsageError(
            f"{path.name}: no CameraInfo topic for --camera auto; pass --camera PROFILE|YAML"
        )
    info = next(iter(rec.messages(topics=[streams.camera_info])), None)
    if info is None:
        raise UsageError(f"{path.name}: {streams.camera_info} has no messages; pass --camera")
    data = info.data
    header = field_value(data, "header")
    frame_id = str(field_value(header, "frame_id") or "")
    extr = _mcap_extrinsics(path)
    source = "MCAP metadata slt_camera"
    if extr is None:
        extr = _tf_extrinsics(rec, streams.tf, frame_id)
        source = f"{streams.tf} ({frame_id})"
    if extr is None:
        raise UsageError(
            f"{path.name}: CameraInfo has no extrinsics and the recording holds neither an "
            "slt_camera metadata record nor a /tf_static camera transform; pass --camera"
        )
    cam = from_camera_info(
        int(field_value(data, "width") or 0),
        int(field_value(data, "height") or 0),
        list(field_value(data, "k", "K")),
        [float(c) for c in _sequence(field_value(data, "d", "D"))],
        str(field_value(data, "distortion_model") or ""),
        extr,
        name="recording",
    )
    return cam, f"CameraInfo {streams.camera_info} + extrinsics from {source}"


def decode_frame(msg: Message) -> NDArray[np.uint8]:
    """Decode an image message into a BGR uint8 array.

    Raises:
        ValueError: If the payload is corrupt or the encoding unsupported.
    """
    import cv2

    data = msg.data
    if msg.msgtype in RAW_TYPES:
        pixels = raw_pixels(
            data.data,
            int(data.width),
            int(data.height),
            str(data.encoding),
            int(getattr(data, "step", 0) or 0),
        )
    else:
        payload = bytes(data.data)
        if not payload or (sniff_format(payload) is None and not payload):
            raise ValueError("empty image payload")
        pixels = imdecode(payload, cv2.IMREAD_UNCHANGED)
    if pixels.dtype != np.uint8:
        pixels = (
            (pixels >> 8).astype(np.uint8) if pixels.dtype == np.uint16 else pixels.astype(np.uint8)
        )
    if min(pixels.shape[:2]) < MIN_FRAME_SIDE:
        raise ValueError(f"image {pixels.shape[1]}x{pixels.shape[0]} too small to process")
    if pixels.ndim == 2:
        pixels = cv2.cvtColor(pixels, cv2.COLOR_GRAY2BGR)
    elif pixels.shape[2] == 4:
        pixels = cv2.cvtColor(pixels, cv2.COLOR_BGRA2BGR)
    out: NDArray[np.uint8] = np.ascontiguousarray(pixels)
    return out


#: JPEG decoding with DCT-domain downscaling (libjpeg scales by 1/2, 1/4, 1/8 while decoding).
_REDUCED_FLAGS = (
    (8, "IMREAD_REDUCED_COLOR_8"),
    (4, "IMREAD_REDUCED_COLOR_4"),
    (2, "IMREAD_REDUCED_COLOR_2"),
)


def decode_reduced(
    msg: Message, target_width: int
) -> tuple[NDArray[np.uint8], tuple[int, int]] | None:
    """Decode a JPEG frame directly at a reduced size, if one still covers ``target_width``.

    libjpeg skips most of the inverse DCT when it scales by 1/2, 1/4 or 1/8, so decoding a
    1280x720 frame at 640x360 costs about a third of a full decode plus resize.

    Args:
        msg: A compressed image message.
        target_width: Width the frame will be processed at, pixels (<= 0: full size).

    Returns:
        The BGR image at the largest reduction whose width is still >= ``target_width``, and the
        recorded ``(width, height)``; None when the frame is not a JPEG, is not reducible for
        this target, or cannot be decoded this way (decode it with :func:`decode_frame`).
    """
    if target_width <= 0 or msg.msgtype in RAW_TYPES:
        return None
    payload = bytes(msg.data.data)
    if sniff_format(payload) != "jpeg":
        return None
    size = jpeg_size(payload)
    if size is None:
        return None
    import cv2

    for factor, flag in _REDUCED_FLAGS:
        if -(-size.width // factor) >= target_width:
            try:
                decoded = imdecode(payload, getattr(cv2, flag))
            except ValueError:
                return None  # decode_frame reports it
            if decoded.ndim != 3 or decoded.dtype != np.uint8:
                return None
            if min(decoded.shape[:2]) < MIN_FRAME_SIDE:
                return None
            return np.ascontiguousarray(decoded), (size.width, size.height)
    return None
