"""``slt camera estimate``: a camera's mounting from a recording's lane lines."""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from itertools import pairwise
from pathlib import Path
from typing import TYPE_CHECKING

from superlane_tools.camera.extrinsics_estimate import (
    ExtrinsicsEstimate,
    FrameLines,
    estimate_extrinsics,
    frame_intrinsics,
    frame_lines,
)
from superlane_tools.camera.focal_motion import (
    MAX_DISTANCE_M,
    SampledLines,
    Track,
    focal_from_frame_pairs,
    too_far,
)
from superlane_tools.camera.model import CameraModel, Intrinsics
from superlane_tools.drive.config import DEFAULT_FIT
from superlane_tools.errors import UsageError
from superlane_tools.lanes import FitParams
from superlane_tools.lanes.fit_height import LanePixels, fit_height
from superlane_tools.lanes.points import lane_points

if TYPE_CHECKING:
    from superlane_tools.scene.recording_frames import RecordingFrames


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
    from superlane_tools.scene.recording_frames import RecordingFrames

    if sum(v is not None for v in (intrinsics, focal_px, hfov_deg)) > 1:
        raise UsageError("give at most one of --intrinsics, --focal-px and --hfov")
    frames = RecordingFrames(recording, topic)
    step = max(1, math.ceil((frames.total or max_frames) / max_frames))
    # with nothing known about the lens, each sampled frame's successor is segmented too: the
    # dashes' motion between the two measures the focal length (given a GNSS track)
    lens_known = intrinsics is not None or focal_px is not None or hfov_deg is not None
    track = None if lens_known else gnss_track(recording)
    got = _sample_frames(frames, step, max_frames, track, (intrinsics, focal_px, hfov_deg))
    used_k, source = got.intrinsics, got.source
    if used_k is None:
        raise UsageError(f"{recording.name}: no decodable camera frame")
    lines = [frame_lines(f.uv, used_k, seed=f.frame) for f in got.sampled]
    est = estimate_extrinsics(lines, used_k, lane_width_m, roll_rad)
    if track is not None:
        if step == 1:  # every frame is sampled: each one's successor is the next sampled one
            got.successors = {
                a.frame: b for a, b in pairwise(got.sampled) if b.frame == a.frame + 1
            }
        measured = _focal_from_motion(got, lines, track, used_k, est)
        if isinstance(measured, str):
            source += f"; focal length not measurable from motion ({measured})"
        else:
            used_k, source = measured
            lines = [frame_lines(f.uv, used_k, seed=f.frame) for f in got.sampled]
            est = estimate_extrinsics(lines, used_k, lane_width_m, roll_rad)
    elif not lens_known:
        source += "; focal length not measurable from motion (no GNSS track)"
    # the height the lane fit of `slt reprocess` (its default parameters) needs for this width
    fit_params = FitParams.from_dict(dict(DEFAULT_FIT))
    est = fit_height(got.pixels, CameraModel(used_k, est.extrinsics), est, lane_width_m, fit_params)
    return CameraEstimate(CameraModel(used_k, est.extrinsics, name=name), est, source, got.span_s)


@dataclass
class _Samples:
    """What the sampled frames (and their successors) show, and the intrinsics they took."""

    sampled: list[SampledLines] = field(default_factory=list)
    pixels: list[LanePixels] = field(default_factory=list)
    successors: dict[int, SampledLines] = field(default_factory=dict)
    intrinsics: Intrinsics | None = None
    source: str = ""
    first_ns: int | None = None
    last_ns: int | None = None
    want_pairs: bool = False
    """Whether successors were segmented to the end (False: consecutive frames too far apart)."""

    @property
    def span_s(self) -> float:
        """Seconds between the first and the last frame looked at."""
        if self.first_ns is None or self.last_ns is None:
            return 0.0
        return (self.last_ns - self.first_ns) / 1e9


def _sample_frames(
    frames: RecordingFrames,
    step: int,
    max_frames: int,
    track: Track | None,
    lens: tuple[Intrinsics | None, float | None, float | None],
) -> _Samples:
    """Segment every ``step``-th frame (and, for the focal length, its successor) for lines.

    Args:
        frames: The recording's camera frames.
        step: Frames between two sampled ones.
        max_frames: Frames sampled at most.
        track: The GNSS track that makes successors worth segmenting, or None.
        lens: The intrinsics options ``(intrinsics, focal_px, hfov_deg)``.
    """
    from superlane_tools.scene.onnx_backend import OnnxSegmentationBackend

    backend = OnnxSegmentationBackend(threads=1)
    got = _Samples(want_pairs=track is not None)
    previous_time: int | None = None
    for index, frame in enumerate(frames):
        got.first_ns = frame.log_time_ns if got.first_ns is None else got.first_ns
        got.last_ns = frame.log_time_ns
        offset = index % step
        if frame.image is None or len(got.sampled) >= max_frames:
            continue
        if offset == 0:
            previous_time = frame.log_time_ns
        if offset and not (got.want_pairs and offset == 1 and step > 1):
            continue
        if offset and too_far(track, previous_time, frame.log_time_ns):
            got.want_pairs = bool(got.successors)  # at a low frame rate, stop segmenting twice
            continue
        height, width = frame.image.shape[:2]
        if got.intrinsics is None:
            got.intrinsics, got.source = frame_intrinsics(width, height, *lens)
        # the lane fit's own lane-marking pixels
        uv, codes = lane_points(backend.segment(frame.image), seed=index)
        item = SampledLines(index, frame.log_time_ns, uv)
        if offset:
            got.successors[index - 1] = item
        else:
            got.sampled.append(item)
            got.pixels.append((uv, codes))
    return got


def _focal_from_motion(
    got: _Samples,
    lines: list[FrameLines | None],
    track: Track,
    k: Intrinsics,
    est: ExtrinsicsEstimate,
) -> tuple[Intrinsics, str] | str:
    """Intrinsics with the focal length measured from the dashes' motion, and their source.

    Returns:
        The intrinsics and where they came from, or why the focal length was not measurable.
    """
    if not got.want_pairs:
        return (
            f"consecutive frames more than {MAX_DISTANCE_M:g} m apart; a higher frame rate "
            "or a slower drive is needed"
        )
    focal = focal_from_frame_pairs(got.sampled, lines, got.successors, track, k, est.extrinsics)
    if isinstance(focal, str):
        return focal
    measured = replace(k, fx=focal.focal_px, fy=focal.focal_px)
    return measured, (
        f"focal length {focal.focal_px:.1f} px MEASURED from the dashed markings' motion "
        f"at GNSS speed ({focal.pairs} line pairs, mean correlation "
        f"{focal.mean_correlation:.2f}); principal point at the centre"
    )
