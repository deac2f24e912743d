"""Camera pitch, yaw, roll and height from the ego lane lines, over many frames.

Per frame, the two ego lane markings are fitted as straight lines ``x = a y + b`` in undistorted
normalised image coordinates near the vehicle (the lower image part, where a curve is still
nearly straight). Roll is a rotation about the optical axis, so the lines are first rotated
back by the roll. Their intersection is then the vanishing point ``(xv, yv)`` of the road
direction, which gives the downward pitch ``atan(-yv)`` and the yaw ``atan(xv cos(pitch))``.
Back-projected onto the road plane with a camera at 1 m, the two lines lie ``w1`` metres apart;
the true lane width ``W`` gives the height ``W / w1``.

Roll moves the back-projected lane sideways: a roll ``r`` puts the lane centre about
``r (h + W^2 / 4h)`` metres off the camera. Assuming the camera rides at the lane centre on
average (mounted on the vehicle's centre line, the driver keeping to the lane centre), each
frame's roll is the one that centres its lane; the median over frames is the estimate. A camera
mounted ``d`` metres off the centre line biases it by ``d / (h + W^2 / 4h)`` (about 1.5 degrees
per 10 cm); pass a known roll instead in that case.

The medians over frames are the estimate, their spread (1.4826 MAD) the per-frame uncertainty,
spread / sqrt(n) that of the median.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from superlane_tools.camera.errors import CameraError
from superlane_tools.camera.model import CameraModel, Extrinsics, Intrinsics
from superlane_tools.errors import UsageError

FloatArray = NDArray[np.float64]
DASHCAM_HFOV_DEG = 60.0
"""Horizontal field of view assumed when nothing is known about the camera (a typical dashcam)."""
MIN_LINE_POINTS = 25
MIN_FRAMES = 3
ROLL_STEP_RAD = 0.01
"""Roll step for the per-frame secant that centres the lane."""
MAX_ROLL_RAD = 0.3
"""Per-frame rolls beyond this (a lane change, a wrong line) are left out of the roll median."""
ROLL_METHOD = "lane centred on average (camera on the vehicle centre line)"


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
        extrinsics: Median pitch, yaw and roll (radians) and the height (metres); x = y = 0.
        pitch_sigma_rad: Spread (1.4826 MAD) of the per-frame pitch, radians.
        yaw_sigma_rad: Spread of the per-frame yaw, radians.
        height_sigma_m: Spread of the per-frame height, metres.
        frames_used: Frames whose two ego lines were found.
        frames_seen: Frames looked at.
        lane_width_m: Lane width the height was scaled with, metres.
        roll_sigma_rad: Spread of the per-frame roll, radians; None when it was not estimated.
        roll_method: How the roll was obtained.
        vp_height_m: Height from the vanishing-point lines alone, metres, when the height was
            then scaled so that the lane fit measures ``lane_width_m`` (None: not scaled).
        fit_frames: Frames whose fitted ego lane width set that scale.
    """

    extrinsics: Extrinsics
    pitch_sigma_rad: float
    yaw_sigma_rad: float
    height_sigma_m: float
    frames_used: int
    frames_seen: int
    lane_width_m: float
    roll_sigma_rad: float | None = None
    roll_method: str = "given"
    vp_height_m: float | None = None
    fit_frames: int = 0

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
            "roll_deg": round(math.degrees(e.roll_rad), 4),
            "roll_method": self.roll_method,
            **(
                {}
                if self.roll_sigma_rad is None
                else {
                    "roll_sigma_deg": round(math.degrees(self.roll_sigma_rad), 4),
                    "roll_median_sigma_deg": round(
                        math.degrees(self.roll_sigma_rad) / math.sqrt(n), 4
                    ),
                }
            ),
            **(
                {}
                if self.vp_height_m is None
                else {
                    "height_method": "scaled so that the lane fit (slt reprocess) measures "
                    "lane_width_m as the median ego-lane width of these frames",
                    "height_vanishing_point_m": round(self.vp_height_m, 4),
                    "height_fit_frames": self.fit_frames,
                }
            ),
        }


def intrinsics_from_hfov(width: int, height: int, hfov_deg: float) -> Intrinsics:
    """Return a distortion-free pinhole with the principal point at the image centre.

    Pixel ``(0, 0)`` is the centre of the first pixel (the convention of every camera model
    here), so the centre is ``((width - 1) / 2, (height - 1) / 2)``.
    """
    if not 10.0 <= hfov_deg <= 170.0:
        raise CameraError(f"horizontal field of view must be 10-170 degrees, got {hfov_deg}")
    f = width / (2.0 * math.tan(math.radians(hfov_deg) / 2.0))
    return Intrinsics(width, height, f, f, (width - 1) / 2.0, (height - 1) / 2.0)


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


def _derotate(lines: FrameLines, roll_rad: float) -> FrameLines:
    """Return the lines as a camera without roll would see them (rotate about the axis)."""
    if roll_rad == 0.0:
        return lines
    c, s = math.cos(roll_rad), math.sin(roll_rad)
    out = []
    for a, b in (lines.left, lines.right):
        # two points of the line, rotated by -roll: (x0, y0) = (c x - s y, s x + c y)
        y = np.array([0.0, 1.0])
        x = a * y + b
        x0, y0 = c * x - s * y, s * x + c * y
        a0 = (x0[1] - x0[0]) / (y0[1] - y0[0])
        out.append((float(a0), float(x0[0] - a0 * y0[0])))
    return FrameLines(out[0], out[1])


def _frame_pose(
    lines: FrameLines, intrinsics: Intrinsics, roll_rad: float = 0.0
) -> tuple[float, float, float, float] | None:
    """Return ``(pitch, yaw, width, centre)`` of one frame, lengths at 1 m camera height.

    ``centre`` is the lane centre's lateral offset from the camera (left positive).
    """
    upright = _derotate(lines, roll_rad)
    (al, bl), (ar, br) = upright.left, upright.right
    yv = (br - bl) / (al - ar)
    xv = al * yv + bl
    pitch = math.atan(-yv)
    yaw = math.atan(xv * math.cos(pitch))
    mount = Extrinsics(1.0, pitch_rad=pitch, yaw_rad=yaw)
    # points on each line a little below the vanishing point down to the image bottom
    y_bottom = (intrinsics.height - intrinsics.cy) / intrinsics.fy
    ys = np.linspace(yv + 0.3 * (y_bottom - yv), y_bottom, 8)
    offsets = []
    for a, b in ((al, bl), (ar, br)):
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
    return pitch, yaw, width, 0.5 * (offsets[0] + offsets[1])


def _frame_roll(lines: FrameLines, intrinsics: Intrinsics, roll_rad: float) -> float | None:
    """Return the roll that centres one frame's lane (a secant step from ``roll_rad``)."""
    here = _frame_pose(lines, intrinsics, roll_rad)
    there = _frame_pose(lines, intrinsics, roll_rad + ROLL_STEP_RAD)
    if here is None or there is None or there[3] == here[3]:
        return None
    return roll_rad - here[3] * ROLL_STEP_RAD / (there[3] - here[3])


def _spread(v: FloatArray) -> float:
    return float(1.4826 * np.median(np.abs(v - np.median(v))))


def estimate_roll(
    lines: Sequence[FrameLines], intrinsics: Intrinsics
) -> tuple[float, float] | None:
    """Return ``(roll, per-frame spread)`` in radians that centres the lane on average.

    Two rounds of per-frame secant steps (the lane centre is nearly linear in the roll); frames
    whose roll exceeds :data:`MAX_ROLL_RAD` are left out. None with fewer than
    :data:`MIN_FRAMES` usable frames.
    """
    roll = 0.0
    rolls = np.zeros(0)
    for _ in range(2):
        found = [_frame_roll(f, intrinsics, roll) for f in lines]
        rolls = np.asarray([r for r in found if r is not None and abs(r) <= MAX_ROLL_RAD])
        if rolls.size < MIN_FRAMES:
            return None
        roll = float(np.median(rolls))
    return roll, _spread(rolls)


def estimate_extrinsics(
    lines: Sequence[FrameLines | None],
    intrinsics: Intrinsics,
    lane_width_m: float = 3.7,
    roll_rad: float | None = None,
) -> ExtrinsicsEstimate:
    """Combine per-frame lane lines into pitch, yaw, roll and height with their spreads.

    Args:
        lines: Per-frame ego lines (None where not found).
        intrinsics: Camera intrinsics the lines were fitted with.
        lane_width_m: Lane width of the road, metres.
        roll_rad: Known roll, radians; None estimates it (the lane centred on average).

    Raises:
        CameraError: If fewer than :data:`MIN_FRAMES` frames have both ego lines.
    """
    if lane_width_m <= 0:
        raise CameraError(f"lane width must be positive, got {lane_width_m} m")
    found = [f for f in lines if f is not None]
    roll_sigma: float | None = None
    roll_method = "given"
    if roll_rad is None:
        rolled = estimate_roll(found, intrinsics)
        if rolled is None:
            roll_rad, roll_method = 0.0, "not estimated (too few frames; assumed 0)"
        else:
            roll_rad, roll_sigma = rolled
            roll_method = ROLL_METHOD
    poses = [p for p in (_frame_pose(f, intrinsics, roll_rad) for f in found) if p]
    if len(poses) < MIN_FRAMES:
        raise CameraError(
            f"only {len(poses)} of {len(lines)} frames show both ego lane lines; "
            f"need {MIN_FRAMES} (a drive on a marked road, camera looking ahead)"
        )
    arr = np.asarray(poses, dtype=np.float64)
    heights = lane_width_m / arr[:, 2]
    med = np.median(arr, axis=0)

    extr = Extrinsics(
        height_m=float(np.median(heights)),
        pitch_rad=float(med[0]),
        roll_rad=roll_rad,
        yaw_rad=float(med[1]),
    )
    return ExtrinsicsEstimate(
        extr,
        _spread(arr[:, 0]),
        _spread(arr[:, 1]),
        _spread(heights),
        len(poses),
        len(lines),
        lane_width_m,
        roll_sigma,
        roll_method,
    )


def frame_intrinsics(
    width: int,
    height: int,
    intrinsics: Intrinsics | None,
    focal_px: float | None,
    hfov_deg: float | None,
) -> tuple[Intrinsics, str]:
    """Return the intrinsics for frames of ``width`` x ``height`` and where they came from.

    At most one of ``intrinsics`` (scaled to the frames), ``focal_px`` and ``hfov_deg`` is
    given; with none, :data:`DASHCAM_HFOV_DEG` is assumed. The principal point of a focal
    length or field of view is the image centre.

    Raises:
        UsageError: For a focal length that is not positive.
    """
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
