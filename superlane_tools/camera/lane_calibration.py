"""Estimate a camera's horizon, pitch, yaw and height from labelled straight lanes in images.

Each labelled lane is a set of image points ``(u, v)`` in pixels. On a flat, straight road the
lanes are parallel lines on the ground, so their images are straight lines ``u = s * v + c`` that
meet at the vanishing point ``(u_vp, v_vp)``. For a camera without roll:

* the vanishing row is the horizon, ``v_vp = cy - fy * tan(pitch)``;
* the vanishing column gives the yaw, ``u_vp - cx = fx * tan(yaw) / cos(pitch)``;
* a ground line at lateral offset ``Y`` metres has image slope
  ``s = du/dv = -(fx / fy) * Y * cos(pitch) / h`` (exact for zero yaw), so adjacent lanes
  ``W`` metres apart differ in slope by ``(fx / fy) * W * cos(pitch) / h``.

Only the ratio focal length / height is observable from lane geometry, so the focal length is an
input (:attr:`LaneCalibrationParams.focal_px`) and the height follows from the lane width.
Frames disagree (pitching on bumps, grades, lane changes), so the estimate takes medians over
frames and reports the spread.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from superlane_tools.camera.errors import CameraError
from superlane_tools.camera.model import CameraModel, Extrinsics, FloatArray, Intrinsics


class ImageLine(NamedTuple):
    """A straight lane in the image, ``u = slope * v + intercept`` (pixels)."""

    slope: float
    """Change of column per row, ``du/dv`` (pixels per pixel)."""
    intercept: float
    """Column at row 0, pixels."""
    rms_px: float
    """Root-mean-square residual of the fit, pixels."""


@dataclass(frozen=True)
class LaneCalibrationParams:
    """How to pick straight lanes and which camera constants to assume.

    Attributes:
        width: Image width in pixels.
        height: Image height in pixels.
        focal_px: Assumed focal length ``fx = fy`` in pixels (not observable from lanes).
        lane_width_m: Mean lane width in metres that fixes the camera height.
        min_points: Fewest labelled points for a lane to be fitted.
        min_span_px: Smallest row span in pixels of a fitted lane.
        max_rms_px: Largest straight-line residual in pixels of a "near-straight" lane.
        adjacent_tolerance: Slope differences outside ``[1 - t, 1 + t]`` times the first median
            are treated as non-adjacent lanes (a lane missing in between) and dropped.
    """

    width: int = 1280
    height: int = 720
    focal_px: float = 1000.0
    lane_width_m: float = 3.75
    min_points: int = 10
    min_span_px: float = 150.0
    max_rms_px: float = 2.0
    adjacent_tolerance: float = 0.4


@dataclass(frozen=True)
class LaneCalibration:
    """A camera estimated from lane labels, with the per-frame spread behind it.

    Attributes:
        camera: The estimated camera (principal point at the image centre, no roll, no
            distortion).
        n_frames: Frames offered.
        n_frames_used: Frames with at least two near-straight lanes.
        horizon_rows: Per-frame vanishing rows in pixels (one per used frame).
        vp_columns: Per-frame vanishing columns in pixels.
        slope_steps: Slope differences ``du/dv`` of adjacent lanes kept for the height.
    """

    camera: CameraModel
    n_frames: int
    n_frames_used: int
    horizon_rows: FloatArray
    vp_columns: FloatArray
    slope_steps: FloatArray

    def summary(self) -> dict[str, float]:
        """Return medians, robust spreads (MAD) and 5/95 % percentiles of the per-frame values."""
        rows, cols = self.horizon_rows, self.vp_columns
        p5, p95 = np.percentile(rows, [5.0, 95.0])
        return {
            "n_frames": float(self.n_frames),
            "n_frames_used": float(self.n_frames_used),
            "horizon_row_median_px": float(np.median(rows)),
            "horizon_row_mad_px": _mad(rows),
            "horizon_row_p5_px": float(p5),
            "horizon_row_p95_px": float(p95),
            "vp_column_median_px": float(np.median(cols)),
            "vp_column_mad_px": _mad(cols),
            "slope_step_median": float(np.median(self.slope_steps)),
            "slope_step_mad": _mad(self.slope_steps),
            "n_slope_steps": float(self.slope_steps.size),
        }


def _mad(values: FloatArray) -> float:
    return float(np.median(np.abs(values - np.median(values))))


def fit_straight_lanes(
    lanes_u: Sequence[Sequence[float]],
    rows_v: Sequence[float],
    params: LaneCalibrationParams,
) -> list[ImageLine]:
    """Fit ``u = s * v + c`` to each labelled lane and keep the near-straight ones.

    Args:
        lanes_u: Per lane, the column in pixels at each row of ``rows_v``; negative = no point
            (the TuSimple ``-2`` convention).
        rows_v: Image rows in pixels (TuSimple ``h_samples``).
        params: Selection thresholds.

    Returns:
        The near-straight lanes, in input order.
    """
    v_all = np.asarray(rows_v, dtype=np.float64)
    fits: list[ImageLine] = []
    for lane in lanes_u:
        u_all = np.asarray(lane, dtype=np.float64)
        if u_all.shape != v_all.shape:
            raise CameraError(f"lane has {u_all.size} points but there are {v_all.size} rows")
        ok = u_all >= 0
        if int(ok.sum()) < params.min_points:
            continue
        u, v = u_all[ok], v_all[ok]
        if float(v.max() - v.min()) < params.min_span_px:
            continue
        slope, intercept = np.polyfit(v, u, 1)
        rms = float(np.sqrt(np.mean((u - (slope * v + intercept)) ** 2)))
        if rms <= params.max_rms_px:
            fits.append(ImageLine(float(slope), float(intercept), rms))
    return fits


def vanishing_point(lines: Sequence[ImageLine]) -> tuple[float, float]:
    """Return the least-squares intersection ``(u, v)`` in pixels of two or more image lines.

    Minimises the sum of squared perpendicular distances to the lines ``u - s v - c = 0``.

    Raises:
        CameraError: With fewer than two lines or (near-)parallel lines only.
    """
    if len(lines) < 2:
        raise CameraError("a vanishing point needs at least two lines")
    slopes = np.array([ln.slope for ln in lines])
    icpts = np.array([ln.intercept for ln in lines])
    norm = np.sqrt(1.0 + slopes * slopes)
    a = np.stack([1.0 / norm, -slopes / norm], axis=1)
    b = icpts / norm
    sol, _, rank, _ = np.linalg.lstsq(a, b, rcond=None)
    if rank < 2:
        raise CameraError("lines are parallel in the image: no vanishing point")
    return float(sol[0]), float(sol[1])


def estimate_camera_from_lanes(
    frames: Iterable[tuple[Sequence[Sequence[float]], Sequence[float]]],
    params: LaneCalibrationParams | None = None,
    name: str = "estimated",
) -> LaneCalibration:
    """Estimate horizon, pitch, yaw and height from per-frame lane labels.

    Args:
        frames: Per frame, ``(lanes_u, rows_v)`` as in :func:`fit_straight_lanes`.
        params: Assumptions and thresholds; defaults suit TuSimple (1280x720).
        name: Name of the resulting camera profile.

    Returns:
        The camera and the per-frame statistics behind it.

    Raises:
        CameraError: If no frame has two near-straight lanes.
    """
    p = params or LaneCalibrationParams()
    rows: list[float] = []
    cols: list[float] = []
    steps: list[float] = []
    n_frames = 0
    for lanes_u, rows_v in frames:
        n_frames += 1
        lines = fit_straight_lanes(lanes_u, rows_v, p)
        if len(lines) < 2:
            continue
        try:
            u_vp, v_vp = vanishing_point(lines)
        except CameraError:
            continue
        cols.append(u_vp)
        rows.append(v_vp)
        steps.extend(np.diff(np.sort([ln.slope for ln in lines])).tolist())
    if not rows:
        raise CameraError(f"none of {n_frames} frames has two near-straight lanes")
    horizon = np.asarray(rows)
    vp_cols = np.asarray(cols)
    all_steps = np.asarray(steps)
    first = float(np.median(all_steps))
    keep = np.abs(all_steps / first - 1.0) <= p.adjacent_tolerance
    kept = all_steps[keep]

    cx, cy = (p.width - 1) / 2.0, (p.height - 1) / 2.0
    f = p.focal_px
    pitch = math.atan((cy - float(np.median(horizon))) / f)
    yaw = math.atan((float(np.median(vp_cols)) - cx) * math.cos(pitch) / f)
    height_m = p.lane_width_m * math.cos(pitch) / float(np.median(kept))
    camera = CameraModel(
        intrinsics=Intrinsics(width=p.width, height=p.height, fx=f, fy=f, cx=cx, cy=cy),
        extrinsics=Extrinsics(height_m=height_m, pitch_rad=pitch, yaw_rad=yaw),
        name=name,
    )
    return LaneCalibration(
        camera=camera,
        n_frames=n_frames,
        n_frames_used=len(rows),
        horizon_rows=horizon,
        vp_columns=vp_cols,
        slope_steps=kept,
    )
