"""``slt camera estimate``: a camera's mounting from a recording's lane lines."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from itertools import pairwise
from pathlib import Path

from superlane_tools.camera.extrinsics_estimate import (
    ExtrinsicsEstimate,
    estimate_extrinsics,
    frame_intrinsics,
    frame_lines,
)
from superlane_tools.camera.focal_motion import (
    MAX_DISTANCE_M,
    SampledLines,
    focal_from_frame_pairs,
    too_far,
)
from superlane_tools.camera.model import CameraModel, Intrinsics
from superlane_tools.drive.config import DEFAULT_FIT
from superlane_tools.errors import UsageError
from superlane_tools.lanes import FitParams
from superlane_tools.lanes.fit_height import LanePixels, fit_height
from superlane_tools.lanes.points import lane_points


@dataclass(frozen=True)
class CameraEstimate:
    """The estimated camera and how it was obtained.

    Attributes:
        camera: Intrinsics (given or assumed) with the estimated extrinsics.
        estimate: The extrinsics estimate with its uncertainty.
        intrinsics_source: Where the intrinsics came from (a profile, a focal length, or an
            assumed field of view).
        span_s: Seconds between the first and the last frame looked at.
    """

    camera: CameraModel
    estimate: ExtrinsicsEstimate
    intrinsics_source: str
    span_s: float = 0.0


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
        hfov_deg: Horizontal field of view (principal point: centre). With none of the three,
            :data:`DASHCAM_HFOV_DEG` is assumed to start with, and the focal length is then
            measured from the dashed markings' motion when the recording has a GNSS track and
            consecutive frames 0.3-5 m apart (:mod:`superlane_tools.camera.focal_motion`).
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
    from superlane_tools.recording.gnss_track import gnss_track
    from superlane_tools.scene.onnx_backend import OnnxSegmentationBackend
    from superlane_tools.scene.recording_frames import RecordingFrames

    if sum(v is not None for v in (intrinsics, focal_px, hfov_deg)) > 1:
        raise UsageError("give at most one of --intrinsics, --focal-px and --hfov")
    frames = RecordingFrames(recording, topic)
    step = max(1, math.ceil((frames.total or max_frames) / max_frames))
    # with nothing known about the lens, each sampled frame's successor is segmented too: the
    # dashes' motion between the two measures the focal length (given a GNSS track)
    lens_known = intrinsics is not None or focal_px is not None or hfov_deg is not None
    track = None if lens_known else gnss_track(recording)
    backend = OnnxSegmentationBackend(threads=1)
    sampled: list[SampledLines] = []
    pixels: list[LanePixels] = []
    successors: dict[int, SampledLines] = {}
    used_k: Intrinsics | None = None
    source = ""
    previous_time: int | None = None
    first_ns: int | None = None
    last_ns: int | None = None
    want_pairs = track is not None
    for index, frame in enumerate(frames):
        first_ns = frame.log_time_ns if first_ns is None else first_ns
        last_ns = frame.log_time_ns
        offset = index % step
        if frame.image is None or len(sampled) >= max_frames:
            continue
        if offset == 0:
            previous_time = frame.log_time_ns
        if offset and not (want_pairs and offset == 1 and step > 1):
            continue
        if offset and too_far(track, previous_time, frame.log_time_ns):
            want_pairs = bool(successors)  # at a low frame rate, stop segmenting twice
            continue
        height, width = frame.image.shape[:2]
        if used_k is None:
            used_k, source = frame_intrinsics(width, height, intrinsics, focal_px, hfov_deg)
        # the lane fit's own lane-marking pixels
        uv, codes = lane_points(backend.segment(frame.image), seed=index)
        item = SampledLines(index, frame.log_time_ns, uv)
        if offset:
            successors[index - 1] = item
        else:
            sampled.append(item)
            pixels.append((uv, codes))
    if used_k is None:
        raise UsageError(f"{recording.name}: no decodable camera frame")
    lines = [frame_lines(f.uv, used_k, seed=f.frame) for f in sampled]
    est = estimate_extrinsics(lines, used_k, lane_width_m, roll_rad)
    if track is not None:
        if step == 1:  # every frame is sampled: each one's successor is the next sampled one
            successors = {a.frame: b for a, b in pairwise(sampled) if b.frame == a.frame + 1}
        focal = (
            focal_from_frame_pairs(sampled, lines, successors, track, used_k, est.extrinsics)
            if want_pairs
            else f"consecutive frames more than {MAX_DISTANCE_M:g} m apart; a higher frame rate "
            "or a slower drive is needed"
        )
        if isinstance(focal, str):
            source += f"; focal length not measurable from motion ({focal})"
        else:
            k = replace(used_k, fx=focal.focal_px, fy=focal.focal_px)
            lines = [frame_lines(f.uv, k, seed=f.frame) for f in sampled]
            est = estimate_extrinsics(lines, k, lane_width_m, roll_rad)
            used_k = k
            source = (
                f"focal length {focal.focal_px:.1f} px MEASURED from the dashed markings' motion "
                f"at GNSS speed ({focal.pairs} line pairs, mean correlation "
                f"{focal.mean_correlation:.2f}); principal point at the centre"
            )
    elif not lens_known:
        source += "; focal length not measurable from motion (no GNSS track)"
    # the height the lane fit of `slt reprocess` (its default parameters) needs for this width
    fit_params = FitParams.from_dict(dict(DEFAULT_FIT))
    est = fit_height(pixels, CameraModel(used_k, est.extrinsics), est, lane_width_m, fit_params)
    span_s = (last_ns - first_ns) / 1e9 if first_ns is not None and last_ns is not None else 0.0
    return CameraEstimate(CameraModel(used_k, est.extrinsics, name=name), est, source, span_s)
