"""Classical Hough-transform ego-lane detector, the baseline of the corridor paper (IV-B).

The usual OpenCV lane-finding pipeline, made to report an ego-corridor width and range in metres:

1. grey image -> Gaussian blur -> Canny edges;
2. trapezoidal region of interest from the bottom corners to ``roi_top_below_horizon_px`` below
   the horizon;
3. probabilistic Hough transform (``cv2.HoughLinesP``) with a short ``minLineLength`` so that the
   far dashes of dashed lines (a few pixels tall at 30 m) still give segments;
4. split into left / right candidates by slope sign (a left boundary rises to the right,
   ``du/dv < 0``) and by side of the principal column at the bottom row; near-horizontal
   segments and segments that do not run towards the vanishing point are dropped;
5. per side, the innermost lane line: candidates are grouped by their lateral ground offset at
   ``near_distance_m`` (flat-ground inverse perspective mapping); the group nearest to the car
   whose segments total at least ``min_support`` of the image height is the ego boundary;
6. fit ``u = a * v + b`` by length-weighted least squares on the group's segment end points, then
   gather every side candidate lying within ``support_tol_px`` of the line and refit once.

Width (m) is the lateral gap between the two fitted lines at ``width_at_m`` ahead (default 10 m,
the distance every method of the availability KPI uses), or at the range when that is nearer.

Range (m) is where the fitted line is still *supported*: the supporting segments are projected to
the ground and chained from the nearest one outwards while the gap to the next is at most
``max_gap_m`` (longer than the 9-12 m gap of dashed lines); the range is the far end of the chain.
The shorter side's range is the corridor range. The line is *not* credited up to the region of
interest's far edge: that extrapolated range would be a constant set by a parameter (so the
time-gap test of the availability KPI would mean nothing), and on a curve the straight
extrapolation leaves the lane long before the region's edge.

A pair is rejected when the lines cross before ``near_distance_m`` or when they do not meet
near the horizon (their crossing row must lie within ``vanishing_tolerance`` of the image height
of the horizon row): two lane boundaries of a flat road meet at the horizon.

Temporal smoothing is optional: :class:`HoughTracker` blends each boundary's ``(a, b)`` with the
previous frame's (exponential, factor ``alpha``) when both frames found it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from superlane_tools.camera.model import CameraModel
from superlane_tools.corridor.geometry import width_distance

HOUGH_SEED = 0x5EED
"""Seed of OpenCV's RNG before each probabilistic Hough transform (reproducible per frame)."""

FloatArray = NDArray[np.float64]


class LineSegment(NamedTuple):
    """An image line segment in pixels, from ``(u0, v0)`` (bottom) to ``(u1, v1)`` (top)."""

    u0: float
    v0: float
    u1: float
    v1: float


class HoughResult(NamedTuple):
    """Ego-lane boundaries found by the Hough baseline.

    Attributes:
        left_line: Left boundary in the image, bottom row to its supported top, or None.
        right_line: Right boundary in the image, or None.
        width_m: Corridor width at ``width_at_m`` ahead (or at the range when nearer), metres
            (NaN if not measured).
        range_m: Supported forward extent of the shorter boundary, metres from the vehicle-frame
            origin (NaN if not measured).
        ok: True when both boundaries were found and form a plausible lane.
        reason: Why not ok (``""`` when ok).
    """

    left_line: LineSegment | None
    right_line: LineSegment | None
    width_m: float
    range_m: float
    ok: bool
    reason: str


@dataclass(frozen=True)
class HoughParams:
    """Parameters of the Hough baseline (pixel sizes are fractions of the image height).

    Defaults were tuned on simulated ``highway_straight`` drives (seeds 1 and 2) and a
    ``highway_curves`` drive of another seed than the challenge set's, and checked on the six
    real TuSimple train frames; see ``docs/reprocess.md`` (Availability).

    Attributes:
        blur_ksize: Gaussian blur kernel size, pixels (odd).
        canny_low: Canny lower hysteresis threshold, grey levels.
        canny_high: Canny upper hysteresis threshold, grey levels.
        roi_top_below_horizon_px: The ROI's top edge lies this many pixels below the horizon.
        roi_top_half_width: Half width of the ROI's top edge, fraction of the image width.
        hough_threshold: Accumulator votes needed for a line.
        min_line_length: Shortest segment, fraction of the image height.
        max_line_gap: Largest gap joined within a segment, fraction of the image height.
        min_abs_slope: Smallest ``|dv/du|``: flatter segments are not lane boundaries.
        vanishing_tolerance: A candidate must cross the horizon row within this fraction of the
            image width from the principal column; the two boundaries must meet within this
            fraction of the image height from the horizon row.
        near_distance_m: Forward distance (m) at which candidates are grouped.
        width_at_m: Forward distance (m) at which the width is measured (at the range when that
            is nearer), from the vehicle-frame origin.
        cluster_m: Candidates within this lateral distance (m) at ``near_distance_m`` form a group.
        min_offset_m: Nearest lateral offset (m) of an ego boundary from the camera; keeps the
            near-vertical side edges of a preceding vehicle out.
        max_offset_m: Farthest lateral offset (m) of an ego boundary from the camera.
        min_support: Smallest total segment length of a boundary group, fraction of the height.
        support_tol_px: Largest distance of a supporting segment's end points from the fitted
            line, fraction of the image height.
        max_gap_m: Largest ground gap (m) between consecutive supporting segments in the range.
    """

    blur_ksize: int = 5
    canny_low: int = 40
    canny_high: int = 120
    roi_top_below_horizon_px: float = 6.0
    roi_top_half_width: float = 0.12
    hough_threshold: int = 10
    min_line_length: float = 0.015
    max_line_gap: float = 0.02
    min_abs_slope: float = 0.3
    vanishing_tolerance: float = 0.15
    near_distance_m: float = 10.0
    width_at_m: float = 10.0
    cluster_m: float = 0.5
    min_offset_m: float = 0.8
    max_offset_m: float = 3.5
    min_support: float = 0.08
    support_tol_px: float = 0.012
    max_gap_m: float = 15.0


def detect_ego_lane(
    image_bgr: NDArray[np.uint8], camera: CameraModel, params: HoughParams | None = None
) -> HoughResult:
    """Find the ego lane's left and right boundaries with Canny + probabilistic Hough.

    Args:
        image_bgr: ``(H, W, 3)`` uint8 BGR image (or ``(H, W)`` grey).
        camera: Camera of the image (resized to the image if needed).
        params: Detector parameters.
    """
    p = params or HoughParams()
    height, width = image_bgr.shape[:2]
    cam = (
        camera
        if (camera.width, camera.height) == (width, height)
        else camera.resized(width, height)
    )
    edges, segs = edges_and_segments(image_bgr, cam, p)
    if segs.shape[0] == 0:
        return HoughResult(None, None, math.nan, math.nan, False, "no lines")
    left = _fit_side(segs, edges, cam, p, left=True)
    right = _fit_side(segs, edges, cam, p, left=False)
    return measure(left, right, cam, p)


def edges_and_segments(
    image_bgr: NDArray[np.uint8], camera: CameraModel, params: HoughParams | None = None
) -> tuple[NDArray[np.uint8], FloatArray]:
    """Return the Canny edges inside the ROI and the ``(N, 4)`` Hough segments.

    Segments are ``u0, v0, u1, v1`` in pixels with ``v0 >= v1`` (bottom end first).

    Args:
        image_bgr: ``(H, W, 3)`` uint8 BGR image (or ``(H, W)`` grey) of the camera's size.
        camera: Camera of the image, at the image's size.
        params: Detector parameters.
    """
    import cv2  # late: heavy import

    p = params or HoughParams()
    grey = image_bgr if image_bgr.ndim == 2 else cv2.cvtColor(image_bgr, cv2.COLOR_BGR2GRAY)
    height, width = grey.shape
    blurred = cv2.GaussianBlur(grey, (p.blur_ksize, p.blur_ksize), 0)
    edges = np.asarray(cv2.Canny(blurred, p.canny_low, p.canny_high), dtype=np.uint8)
    edges &= _roi_mask(height, width, camera, p)
    # the probabilistic transform samples edge points with the calling thread's RNG, whose
    # state depends on what that thread ran before: seed it, so a frame's segments do not
    # depend on which worker took it (or on the frames before it)
    cv2.setRNGSeed(HOUGH_SEED)
    found = cv2.HoughLinesP(
        edges,
        rho=1,
        theta=np.pi / 180,
        threshold=p.hough_threshold,
        minLineLength=max(2.0, p.min_line_length * height),
        maxLineGap=max(1.0, p.max_line_gap * height),
    )
    if found is None:
        return edges, np.zeros((0, 4))
    segs = found.reshape(-1, 4).astype(np.float64)
    flip = segs[:, 1] < segs[:, 3]
    segs[flip] = segs[flip][:, [2, 3, 0, 1]]
    return edges, segs


class _Boundary(NamedTuple):
    a: float  # du/dv
    b: float  # u at v = 0
    v_top: float  # image row of the supported far end
    range_m: float  # forward ground distance of the supported far end


def _roi_mask(height: int, width: int, cam: CameraModel, p: HoughParams) -> NDArray[np.uint8]:
    import cv2  # late: heavy import

    top = float(np.clip(cam.horizon_row() + p.roi_top_below_horizon_px, 0, height - 2))
    cx = cam.intrinsics.cx
    half = p.roi_top_half_width * width
    poly = np.array(
        [[0, height - 1], [cx - half, top], [cx + half, top], [width - 1, height - 1]],
        dtype=np.int32,
    )
    mask = np.zeros((height, width), dtype=np.uint8)
    cv2.fillPoly(mask, [poly], 255)
    return mask


def _row_at_distance(cam: CameraModel, x_m: float) -> float:
    uv, _ = cam.project(np.array([[x_m, 0.0, 0.0]]))
    return float(uv[0, 1])


def _fit_side(
    segs: FloatArray, edges: NDArray[np.uint8], cam: CameraModel, p: HoughParams, *, left: bool
) -> _Boundary | None:
    """Select and fit one side's ego boundary, and measure how far it is supported."""
    u0, v0, u1, v1 = segs.T
    du, dv = u1 - u0, v1 - v0
    steep = (np.abs(dv) >= p.min_abs_slope * np.abs(du)) & (dv != 0)
    a = np.divide(du, dv, out=np.zeros_like(du), where=dv != 0)
    b = u0 - a * v0
    cx = cam.intrinsics.cx
    u_bottom = a * (cam.height - 1.0) + b
    side = (a < 0) & (u_bottom < cx) if left else (a > 0) & (u_bottom > cx)
    u_horizon = a * cam.horizon_row() + b
    converging = np.abs(u_horizon - cx) <= p.vanishing_tolerance * cam.width
    cand = np.flatnonzero(steep & side & converging)
    if cand.size == 0:
        return None
    v_near = _row_at_distance(cam, p.near_distance_m)
    xy, valid = cam.ground_points(
        np.stack([a[cand] * v_near + b[cand], np.full(cand.size, v_near)], 1)
    )
    offset = np.where(valid, xy[:, 1], np.nan)
    keep = (
        np.isfinite(offset)
        & (np.abs(offset) >= p.min_offset_m)
        & (np.abs(offset) <= p.max_offset_m)
    )
    cand, offset = cand[keep], offset[keep]
    length = np.hypot(du, dv)
    need = p.min_support * cam.height
    for i in np.argsort(np.abs(offset)):
        group = cand[np.abs(offset - offset[i]) <= p.cluster_m]
        if length[group].sum() >= need:
            break
    else:
        return None
    side_idx = np.flatnonzero(steep & side)
    tol = p.support_tol_px * cam.height
    line = _fit_line(segs[group], length[group])
    support = group
    for _ in range(2):
        dist = np.maximum(
            np.abs(line[0] * v0[side_idx] + line[1] - u0[side_idx]),
            np.abs(line[0] * v1[side_idx] + line[1] - u1[side_idx]),
        )
        support = side_idx[dist <= tol]
        if support.size == 0:
            support = group
        line = _fit_line(segs[support], length[support])
    return _supported_range(line, edges, cam, p)


def _fit_line(segs: FloatArray, weights: FloatArray) -> tuple[float, float]:
    """Length-weighted least-squares fit of ``u = a * v + b`` through segment end points."""
    v = np.concatenate([segs[:, 1], segs[:, 3]])
    u = np.concatenate([segs[:, 0], segs[:, 2]])
    w = np.concatenate([weights, weights])
    design = np.stack([v, np.ones_like(v)], 1) * np.sqrt(w)[:, None]
    (a, b), *_ = np.linalg.lstsq(design, u * np.sqrt(w), rcond=None)
    return float(a), float(b)


def _supported_range(
    line: tuple[float, float], edges: NDArray[np.uint8], cam: CameraModel, p: HoughParams
) -> _Boundary | None:
    """Walk up the fitted line row by row and return how far edge pixels support it.

    A row supports the line when a Canny edge pixel lies within ``support_tol_px`` of it; the
    supported rows are chained from the bottom while the ground gap between consecutive ones is
    at most ``max_gap_m``.
    """
    a, b = line
    height, width = edges.shape
    top = int(np.clip(math.ceil(cam.horizon_row() + p.roi_top_below_horizon_px), 0, height - 1))
    rows = np.arange(height - 1, top - 1, -1)
    u = np.rint(a * rows + b).astype(np.intp)
    tol = max(1, round(p.support_tol_px * height))
    cols = u[:, None] + np.arange(-tol, tol + 1)[None, :]
    inside = (cols >= 0) & (cols < width)
    hit = (edges[rows[:, None], np.clip(cols, 0, width - 1)] > 0) & inside
    supported = rows[hit.any(axis=1)]
    if supported.size == 0:
        return None
    xy, valid = cam.ground_points(
        np.stack([a * supported + b, supported.astype(np.float64)], axis=1)
    )
    x = xy[valid, 0]
    v_ok = supported[valid]
    if x.size == 0:
        return None
    gaps = np.flatnonzero(np.diff(x) > p.max_gap_m)
    last = int(gaps[0]) if gaps.size else x.size - 1
    return _Boundary(a, b, float(v_ok[last]), float(x[last]))


def _segment(bound: _Boundary, bottom: float) -> LineSegment:
    return LineSegment(
        bound.a * bottom + bound.b, bottom, bound.a * bound.v_top + bound.b, bound.v_top
    )


def measure(
    left: _Boundary | None, right: _Boundary | None, cam: CameraModel, p: HoughParams
) -> HoughResult:
    """Turn the fitted boundaries into a :class:`HoughResult` with width and range in metres."""
    bottom = cam.height - 1.0
    left_seg = _segment(left, bottom) if left else None
    right_seg = _segment(right, bottom) if right else None
    if left is None or right is None:
        missing = "no left boundary" if left is None else "no right boundary"
        if left is None and right is None:
            missing = "no boundaries"
        return HoughResult(left_seg, right_seg, math.nan, math.nan, False, missing)
    reach = min(left.range_m, right.range_m)
    v_at = _row_at_distance(cam, width_distance(p.width_at_m, reach))
    uv = np.array([[left.a * v_at + left.b, v_at], [right.a * v_at + right.b, v_at]])
    xy, valid = cam.ground_points(uv)
    if not valid.all():
        return HoughResult(left_seg, right_seg, math.nan, math.nan, False, "above the horizon")
    width = float(xy[0, 1] - xy[1, 1])
    if not width > 0:
        return HoughResult(left_seg, right_seg, width, reach, False, "boundaries cross")
    if left.a != right.a:
        v_meet = (right.b - left.b) / (left.a - right.a)
        if abs(v_meet - cam.horizon_row()) > p.vanishing_tolerance * cam.height:
            return HoughResult(
                left_seg, right_seg, width, reach, False, "no common vanishing point"
            )
    return HoughResult(left_seg, right_seg, width, reach, True, "")


@dataclass
class HoughTracker:
    """Hough baseline with optional exponential smoothing of the boundaries across frames.

    Attributes:
        camera: Camera of the images.
        params: Detector parameters.
        alpha: Weight of the current frame (1.0 = no smoothing).
    """

    camera: CameraModel
    params: HoughParams = field(default_factory=HoughParams)
    alpha: float = 1.0
    _left: _Boundary | None = field(default=None, init=False, repr=False)
    _right: _Boundary | None = field(default=None, init=False, repr=False)

    def update(self, image_bgr: NDArray[np.uint8]) -> HoughResult:
        """Detect the ego lane in the next frame and return the smoothed result."""
        height, width = image_bgr.shape[:2]
        cam = self.camera
        if (cam.width, cam.height) != (width, height):
            cam = cam.resized(width, height)
        p = self.params
        edges, segs = edges_and_segments(image_bgr, cam, p)
        left = _fit_side(segs, edges, cam, p, left=True) if segs.shape[0] else None
        right = _fit_side(segs, edges, cam, p, left=False) if segs.shape[0] else None
        self._left = self._blend(self._left, left)
        self._right = self._blend(self._right, right)
        if left is None or right is None:
            return measure(left, right, cam, p)
        return measure(self._left, self._right, cam, p)

    def _blend(self, old: _Boundary | None, new: _Boundary | None) -> _Boundary | None:
        if new is None or old is None or self.alpha >= 1.0:
            return new
        k = self.alpha
        return _Boundary(
            k * new.a + (1 - k) * old.a, k * new.b + (1 - k) * old.b, new.v_top, new.range_m
        )
