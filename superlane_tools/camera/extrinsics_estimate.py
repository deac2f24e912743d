"""Camera pitch, yaw and height from the lane lines' vanishing point, over many frames.

Per frame, the two ego lane markings are fitted as straight lines ``x = a y + b`` in undistorted
normalised image coordinates near the vehicle (the lower image part, where a curve is still
nearly straight). Their intersection is the vanishing point ``(xv, yv)`` of the road direction,
which gives the downward pitch ``atan(-yv)`` and the yaw ``atan(xv cos(pitch))`` (roll = 0).
Back-projected onto the road plane with a camera at 1 m, the two lines lie ``w1`` metres apart;
the true lane width ``W`` gives the height ``W / w1``. The medians over frames are the estimate,
their spread (1.4826 MAD) the per-frame uncertainty, spread / sqrt(n) that of the median.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from superlane_tools.camera.errors import CameraError
from superlane_tools.camera.model import CameraModel, Extrinsics, Intrinsics

FloatArray = NDArray[np.float64]
DASHCAM_HFOV_DEG = 60.0
"""Horizontal field of view assumed when nothing is known about the camera (a typical dashcam)."""
MIN_LINE_POINTS = 25
MIN_FRAMES = 3


@dataclass(frozen=True)
class FrameLines:
    """The ego lane lines of one frame, ``x = a y + b`` in normalised coordinates.

    Attributes:
        left: ``(a, b)`` of the left ego line.
        right: ``(a, b)`` of the right ego line.
    """

    left: tuple[float, float]
    right: tuple[float, float]


@dataclass(frozen=True)
class ExtrinsicsEstimate:
    """Estimated camera mounting with its uncertainty.

    Attributes:
        extrinsics: Median pitch and yaw (radians) and the height (metres); roll 0, x = y = 0.
        pitch_sigma_rad: Spread (1.4826 MAD) of the per-frame pitch, radians.
        yaw_sigma_rad: Spread of the per-frame yaw, radians.
        height_sigma_m: Spread of the per-frame height, metres.
        frames_used: Frames whose two ego lines were found.
        frames_seen: Frames looked at.
        lane_width_m: Lane width the height was scaled with, metres.
    """

    extrinsics: Extrinsics
    pitch_sigma_rad: float
    yaw_sigma_rad: float
    height_sigma_m: float
    frames_used: int
    frames_seen: int
    lane_width_m: float

    def summary(self) -> dict[str, float | int | str]:
        """Return a YAML-ready mapping with degrees for the angles."""
        n = max(1, self.frames_used)
        e = self.extrinsics
        return {
            "method": "vanishing point of the ego lane lines + lane width",
            "frames_used": self.frames_used,
            "frames_seen": self.frames_seen,
            "lane_width_m": self.lane_width_m,
            "pitch_deg": round(math.degrees(e.pitch_rad), 4),
            "pitch_sigma_deg": round(math.degrees(self.pitch_sigma_rad), 4),
            "pitch_median_sigma_deg": round(math.degrees(self.pitch_sigma_rad) / math.sqrt(n), 4),
            "yaw_deg": round(math.degrees(e.yaw_rad), 4),
            "yaw_sigma_deg": round(math.degrees(self.yaw_sigma_rad), 4),
            "height_m": round(e.height_m, 4),
            "height_sigma_m": round(self.height_sigma_m, 4),
            "height_median_sigma_m": round(self.height_sigma_m / math.sqrt(n), 4),
            "roll": "not estimated (assumed 0)",
        }


def intrinsics_from_hfov(width: int, height: int, hfov_deg: float) -> Intrinsics:
    """Return a distortion-free pinhole with the principal point at the image centre."""
    if not 10.0 <= hfov_deg <= 170.0:
        raise CameraError(f"horizontal field of view must be 10-170 degrees, got {hfov_deg}")
    f = width / (2.0 * math.tan(math.radians(hfov_deg) / 2.0))
    return Intrinsics(width, height, f, f, width / 2.0, height / 2.0)


def _ransac_line(
    y: FloatArray, x: FloatArray, tol: float, rng: np.random.Generator, trials: int = 60
) -> tuple[float, float, int] | None:
    """Fit ``x = a y + b`` robustly; return ``(a, b, inliers)`` or None."""
    n = x.size
    if n < MIN_LINE_POINTS:
        return None
    best: NDArray[np.bool_] | None = None
    best_count = 0
    for _ in range(trials):
        i, j = rng.choice(n, 2, replace=False)
        if abs(y[i] - y[j]) < 1e-6:
            continue
        a = (x[i] - x[j]) / (y[i] - y[j])
        b = x[i] - a * y[i]
        inl = np.abs(x - (a * y + b)) < tol
        count = int(inl.sum())
        if count > best_count:
            best, best_count = inl, count
    if best is None or best_count < MIN_LINE_POINTS:
        return None
    a, b = np.polyfit(y[best], x[best], 1)
    return float(a), float(b), best_count


def frame_lines(
    uv: FloatArray, intrinsics: Intrinsics, seed: int = 0, lower_fraction: float = 0.42
) -> FrameLines | None:
    """Fit the two ego lane lines of one frame from its lane-marking pixels.

    Args:
        uv: Lane-marking pixels ``(N, 2)`` ``(u, v)`` at the intrinsics' image size.
        intrinsics: Camera intrinsics (distortion is removed before fitting).
        seed: RANSAC seed.
        lower_fraction: Use pixels in this lower fraction of the image (near the vehicle).

    Returns:
        The two lines, or None when either is not found or they do not converge ahead.
    """
    if uv.shape[0] < 2 * MIN_LINE_POINTS:
        return None
    keep = uv[:, 1] >= intrinsics.height * (1.0 - lower_fraction)
    pts = uv[keep]
    if pts.shape[0] < 2 * MIN_LINE_POINTS:
        return None
    cam = CameraModel(intrinsics, Extrinsics(1.0))
    xn, yn = cam.normalized(pts)
    rng = np.random.default_rng(seed)
    tol = 4.0 / intrinsics.fx  # 4 pixels
    centre = (intrinsics.width / 2.0 - intrinsics.cx) / intrinsics.fx
    y_bottom = (intrinsics.height - intrinsics.cy) / intrinsics.fy
    lines = []
    for side in (xn < centre, xn >= centre):
        # the ego line is the innermost of the side's lines (an outer solid line has more pixels)
        ys, xs = yn[side], xn[side]
        found: list[tuple[float, float]] = []
        for _ in range(3):
            fit = _ransac_line(ys, xs, tol, rng)
            if fit is None:
                break
            a, b, _count = fit
            found.append((a, b))
            rest = np.abs(xs - (a * ys + b)) >= 3.0 * tol
            ys, xs = ys[rest], xs[rest]
        if not found:
            return None
        lines.append(min(found, key=lambda ab: abs(ab[0] * y_bottom + ab[1] - centre)))
    (al, bl), (ar, br) = lines
    if not (al < 0.0 < ar):  # left line leans right going up, right line leans left
        return None
    return FrameLines((al, bl), (ar, br))


def _frame_pose(lines: FrameLines, intrinsics: Intrinsics) -> tuple[float, float, float] | None:
    """Return ``(pitch, yaw, width at 1 m height)`` of one frame's lines."""
    (al, bl), (ar, br) = lines.left, lines.right
    yv = (br - bl) / (al - ar)
    xv = al * yv + bl
    pitch = math.atan(-yv)
    yaw = math.atan(xv * math.cos(pitch))
    mount = Extrinsics(1.0, pitch_rad=pitch, yaw_rad=yaw)
    # points on each line a little below the vanishing point down to the image bottom
    y_bottom = (intrinsics.height - intrinsics.cy) / intrinsics.fy
    ys = np.linspace(yv + 0.3 * (y_bottom - yv), y_bottom, 8)
    offsets = []
    for a, b in (lines.left, lines.right):
        xs = a * ys + b
        uv = np.stack([xs * intrinsics.fx + intrinsics.cx, ys * intrinsics.fy + intrinsics.cy], 1)
        # normalised coordinates are already undistorted: use a distortion-free twin
        pin = CameraModel(
            Intrinsics(
                intrinsics.width, intrinsics.height, intrinsics.fx, intrinsics.fy,
                intrinsics.cx, intrinsics.cy,
            ),
            mount,
        )  # fmt: skip
        ground, ok = pin.ground_points(uv)
        if not ok.any():
            return None
        offsets.append(float(np.median(ground[ok, 1])))
    width = offsets[0] - offsets[1]
    if not width > 0.0:
        return None
    return pitch, yaw, width


def estimate_extrinsics(
    lines: Sequence[FrameLines | None], intrinsics: Intrinsics, lane_width_m: float = 3.7
) -> ExtrinsicsEstimate:
    """Combine per-frame lane lines into pitch, yaw and height with their spreads.

    Raises:
        CameraError: If fewer than :data:`MIN_FRAMES` frames have both ego lines.
    """
    if lane_width_m <= 0:
        raise CameraError(f"lane width must be positive, got {lane_width_m} m")
    poses = [p for p in (_frame_pose(f, intrinsics) for f in lines if f is not None) if p]
    if len(poses) < MIN_FRAMES:
        raise CameraError(
            f"only {len(poses)} of {len(lines)} frames show both ego lane lines; "
            f"need {MIN_FRAMES} (a drive on a marked road, camera looking ahead)"
        )
    arr = np.asarray(poses, dtype=np.float64)
    heights = lane_width_m / arr[:, 2]
    med = np.median(arr, axis=0)

    def spread(v: FloatArray) -> float:
        return float(1.4826 * np.median(np.abs(v - np.median(v))))

    extr = Extrinsics(
        height_m=float(np.median(heights)), pitch_rad=float(med[0]), yaw_rad=float(med[1])
    )
    return ExtrinsicsEstimate(
        extr,
        spread(arr[:, 0]),
        spread(arr[:, 1]),
        spread(heights),
        len(poses),
        len(lines),
        lane_width_m,
    )
