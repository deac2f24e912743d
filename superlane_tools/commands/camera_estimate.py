"""``slt camera estimate``: a camera's mounting from a recording's lane lines."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from superlane_tools.camera.extrinsics_estimate import (
    DASHCAM_HFOV_DEG,
    ExtrinsicsEstimate,
    FrameLines,
    estimate_extrinsics,
    frame_lines,
    intrinsics_from_hfov,
)
from superlane_tools.camera.model import CameraModel, Intrinsics
from superlane_tools.errors import UsageError
from superlane_tools.hierarchy import LEAF_IDS
from superlane_tools.lanes import CODE_OF


def _lane_lut() -> NDArray[np.bool_]:
    lut = np.zeros(256, dtype=bool)
    for node in CODE_OF:
        leaf = LEAF_IDS.get(node)
        if leaf is not None:
            lut[leaf] = True
    return lut


_LANE_LUT = _lane_lut()


@dataclass(frozen=True)
class CameraEstimate:
    """The estimated camera and how it was obtained.

    Attributes:
        camera: Intrinsics (given or assumed) with the estimated extrinsics.
        estimate: The extrinsics estimate with its uncertainty.
        intrinsics_source: Where the intrinsics came from (a profile, a focal length, or an
            assumed field of view).
    """

    camera: CameraModel
    estimate: ExtrinsicsEstimate
    intrinsics_source: str


def estimate_camera(
    recording: Path,
    *,
    intrinsics: Intrinsics | None = None,
    focal_px: float | None = None,
    hfov_deg: float | None = None,
    lane_width_m: float = 3.7,
    max_frames: int = 60,
    topic: str | None = None,
    name: str = "estimated",
    roll_rad: float | None = None,
) -> CameraEstimate:
    """Estimate pitch, yaw, roll and height from lane lines over up to ``max_frames`` frames.

    Args:
        recording: Recording with a camera topic (images or video).
        intrinsics: Known intrinsics (e.g. from ``slt camera calibrate``); scaled to the frames.
        focal_px: Focal length in pixels at the recorded size (principal point: centre).
        hfov_deg: Horizontal field of view (principal point: centre); with none of the three,
            :data:`DASHCAM_HFOV_DEG` is assumed.
        lane_width_m: Lane width of the road driven, metres.
        max_frames: Frames segmented, evenly spread over the recording.
        topic: Camera topic (default: the first image topic).
        name: Profile name.
        roll_rad: Known roll, radians; None estimates it, assuming the camera rides at the lane
            centre on average.

    Raises:
        UsageError: For contradictory intrinsics options.
        CameraError: If too few frames show both ego lines.
    """
    from superlane_tools.scene.onnx_backend import OnnxSegmentationBackend
    from superlane_tools.scene.recording_frames import RecordingFrames

    if sum(v is not None for v in (intrinsics, focal_px, hfov_deg)) > 1:
        raise UsageError("give at most one of --intrinsics, --focal-px and --hfov")
    frames = RecordingFrames(recording, topic)
    step = max(1, math.ceil((frames.total or max_frames) / max_frames))
    backend = OnnxSegmentationBackend(threads=1)
    lines: list[FrameLines | None] = []
    used_k: Intrinsics | None = None
    source = ""
    for index, frame in enumerate(frames):
        if index % step or frame.image is None or len(lines) >= max_frames:
            continue
        height, width = frame.image.shape[:2]
        if used_k is None:
            used_k, source = _intrinsics(width, height, intrinsics, focal_px, hfov_deg)
        labels = backend.segment(frame.image)
        rows, cols = np.nonzero(_LANE_LUT[labels])
        uv = np.stack([cols, rows], axis=1).astype(np.float64)
        lines.append(frame_lines(uv, used_k, seed=index))
    if used_k is None:
        raise UsageError(f"{recording.name}: no decodable camera frame")
    est = estimate_extrinsics(lines, used_k, lane_width_m, roll_rad)
    return CameraEstimate(CameraModel(used_k, est.extrinsics, name=name), est, source)


def _intrinsics(
    width: int,
    height: int,
    intrinsics: Intrinsics | None,
    focal_px: float | None,
    hfov_deg: float | None,
) -> tuple[Intrinsics, str]:
    if intrinsics is not None:
        k = intrinsics
        if (k.width, k.height) != (width, height):
            k = k.scaled(width, height)
        return k, "given intrinsics"
    if focal_px is not None:
        if focal_px <= 0:
            raise UsageError(f"--focal-px must be positive, got {focal_px}")
        return (
            Intrinsics(width, height, focal_px, focal_px, (width - 1) / 2.0, (height - 1) / 2.0),
            f"focal length {focal_px:g} px, principal point at the image centre",
        )
    hfov = hfov_deg if hfov_deg is not None else DASHCAM_HFOV_DEG
    what = (
        "given"
        if hfov_deg is not None
        else "ASSUMED (typical dashcam; pass --hfov or --intrinsics)"
    )
    return (
        intrinsics_from_hfov(width, height, hfov),
        f"horizontal field of view {hfov:g} deg {what}, principal point at the centre",
    )
