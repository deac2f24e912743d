"""The camera of a recording: CameraInfo intrinsics plus extrinsics from metadata or /tf_static."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from superlane_tools.camera.metadata import (
    METADATA_NAME,
    extrinsics_from_metadata,
    extrinsics_from_tf,
)
from superlane_tools.camera.model import CameraModel, Extrinsics
from superlane_tools.errors import UsageError
from superlane_tools.recording.base import Recording, field_value
from superlane_tools.recording.streams import Streams


def _sequence(value: Any) -> list[Any]:
    """Return a message's array field as a list (None -> []); rosbags gives numpy arrays."""
    return [] if value is None else list(value)


def _metadata_extrinsics(rec: Recording) -> Extrinsics | None:
    record = rec.metadata().get(METADATA_NAME)
    if record is None:
        return None
    try:
        return extrinsics_from_metadata(record)
    except (KeyError, ValueError):  # odd metadata: fall back to /tf_static
        return None


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


def camera_sidecars(path: Path) -> tuple[Path, ...]:
    """Return the profiles beside a recording that ``--camera auto`` reads, in that order.

    ``<recording>.camera.yaml`` (``dash.mcap.camera.yaml``), then ``<stem>.camera.yaml``
    (``dash.camera.yaml``, what ``slt camera estimate dash.mcap`` writes by default); a ROS 2
    bag folder ``drive/`` has one: ``drive.camera.yaml`` next to it.
    """
    stem = path.name.removesuffix(path.suffix) or path.name
    names = dict.fromkeys((f"{path.name}.camera.yaml", f"{stem}.camera.yaml"))
    return tuple(path.parent / name for name in names)


def camera_sidecar(path: Path) -> Path:
    """Return the profile beside a recording that ``--camera auto`` reads.

    The first of :func:`camera_sidecars` that exists, else the default ``<stem>.camera.yaml``.
    """
    candidates = camera_sidecars(path)
    return next((p for p in candidates if p.is_file()), candidates[-1])


def resolve_camera(rec: Recording, streams: Streams, camera: str) -> tuple[CameraModel, str]:
    """Return the camera and a sentence saying where it came from.

    ``auto`` takes the intrinsics from the first CameraInfo and the extrinsics from the MCAP
    ``slt_camera`` metadata record or from ``/tf_static``; then a profile beside the recording
    (:func:`camera_sidecar`, e.g. from ``slt camera estimate``); anything else is a profile name
    or a camera YAML file.

    Raises:
        UsageError: If ``auto`` finds no calibration or no extrinsics.
        CameraError: If a profile or the CameraInfo is invalid.
    """
    from superlane_tools.camera.profiles import load_camera
    from superlane_tools.camera.ros import from_camera_info

    path = rec.path
    if camera != "auto":
        return load_camera(camera), f"camera profile {camera}"
    sidecar = camera_sidecar(path)
    hint = (
        f"pass --camera PROFILE|YAML, or run `slt camera estimate {path.name}` (it writes "
        f"{sidecar.name}, which --camera auto reads; `slt camera calibrate` on chessboard "
        "photos gives it the intrinsics)"
    )
    if not streams.camera_info:
        if sidecar.is_file():
            return load_camera(sidecar), f"camera profile {sidecar.name} beside the recording"
        raise UsageError(f"{path.name}: no CameraInfo topic for --camera auto; {hint}")
    info = next(iter(rec.messages(topics=[streams.camera_info])), None)
    if info is None:
        raise UsageError(f"{path.name}: {streams.camera_info} has no messages; pass --camera")
    data = info.data
    header = field_value(data, "header")
    frame_id = str(field_value(header, "frame_id") or "")
    extr = _metadata_extrinsics(rec)
    source = "MCAP metadata slt_camera"
    if extr is None:
        extr = _tf_extrinsics(rec, streams.tf, frame_id)
        source = f"{streams.tf} ({frame_id})"
    if extr is None:
        if sidecar.is_file():
            return load_camera(sidecar), f"camera profile {sidecar.name} beside the recording"
        raise UsageError(
            f"{path.name}: CameraInfo has no extrinsics and the recording holds neither an "
            f"slt_camera metadata record nor a /tf_static camera transform; {hint}"
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
