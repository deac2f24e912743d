"""Classical Hough-transform ego-lane detector, the baseline of the corridor paper (IV-B).

Pipeline: grey image -> Gaussian blur -> Canny edges -> trapezoidal region of interest below the
horizon -> probabilistic Hough transform (``cv2.HoughLinesP``) -> left / right boundary
selection -> robust averaging -> corridor width and range in metres through the camera model.

Boundary selection: a segment is a left-boundary candidate when it rises to the right in the
image (``du/dv < 0``), meets the bottom row left of the principal column and crosses the horizon
row near the principal column (lanes run roughly along the heading); right candidates mirror
that. On each side the candidate meeting the bottom row nearest to the principal column
is taken, together with every candidate of that side whose bottom crossing lies within
``cluster_m`` of it (lateral ground distance at the bottom row); the boundary is the
length-weighted median of their lines ``u = a * v + b``.

Width (m) is the lateral gap between the two boundaries at ``near_distance_m`` ahead (flat-ground
inverse perspective mapping); range (m) is the forward distance of the farther end of the
shorter-reaching side's supporting segments.

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
        left_line: Left boundary in the image, or None.
        right_line: Right boundary in the image, or None.
        width_m: Corridor width at the near distance, metres (NaN if not measured).
        range_m: Forward extent of the supported boundaries, metres (NaN if not measured).
        ok: True when both boundaries were found and the width is positive.
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
    """Parameters of the Hough baseline (pixels refer to the input image).

    Attributes:
        blur_ksize: Gaussian blur kernel size, pixels (odd).
        canny_low: Canny lower hysteresis threshold, grey levels.
        canny_high: Canny upper hysteresis threshold, grey levels.
        roi_top_below_horizon_px: The ROI starts this many pixels below the horizon.
        roi_top_half_width: Half width of the ROI's top edge, fraction of the image width.
        hough_threshold: Accumulator votes needed for a line.
        min_line_length_px: Shortest segment, fraction of the image height.
        max_line_gap_px: Largest gap joined within a segment, fraction of the image height.
        min_abs_slope: Smallest ``|dv/du|``: flatter segments are not lane boundaries.
        vanishing_tolerance: A boundary must cross the horizon row within this fraction of the
            image width from the principal column (lanes run roughly along the heading).
        cluster_m: Candidates within this lateral distance (m) at the bottom row are averaged.
        near_distance_m: Forward distance at which the width is measured, metres.
    """

    blur_ksize: int = 5
    canny_low: int = 50
    canny_high: int = 150
    roi_top_below_horizon_px: float = 15.0
    roi_top_half_width: float = 0.1
    hough_threshold: int = 25
    min_line_length_px: float = 0.04
    max_line_gap_px: float = 0.03
    min_abs_slope: float = 0.3
    vanishing_tolerance: float = 0.15
    cluster_m: float = 0.6
    near_distance_m: float = 10.0


def detect_ego_lane(
    image_bgr: NDArray[np.uint8], camera: CameraModel, params: HoughParams | None = None
) -> HoughResult:
    """Find the ego lane's left and right boundaries with Canny + probabilistic Hough.

    Args:
        image_bgr: ``(H, W, 3)`` uint8 BGR image (or ``(H, W)`` grey).
        camera: Camera of the image (resized to the image if needed).
        params: Detector parameters.
    """
    import cv2  # late: heavy import

    p = params or HoughParams()
    grey = image_bgr if image_bgr.ndim == 2 else cv2.cvtColor(image_bgr, cv2.COLOR_BGR2GRAY)
    height, width = grey.shape
    cam = (
        camera
        if (camera.width, camera.height) == (width, height)
        else camera.resized(width, height)
    )
    blurred = cv2.GaussianBlur(grey, (p.blur_ksize, p.blur_ksize), 0)
    edges = np.asarray(cv2.Canny(blurred, p.canny_low, p.canny_high), dtype=np.uint8)
    edges &= _roi_mask(height, width, cam, p)
    found = cv2.HoughLinesP(
        edges,
        rho=1,
        theta=np.pi / 180,
        threshold=p.hough_threshold,
        minLineLength=max(2.0, p.min_line_length_px * height),
        maxLineGap=max(1.0, p.max_line_gap_px * height),
    )
    if found is None:
        return HoughResult(None, None, math.nan, math.nan, False, "no lines")
    segs = found.reshape(-1, 4).astype(np.float64)
    left = _select_side(segs, cam, p, left=True)
    right = _select_side(segs, cam, p, left=False)
    return measure(left, right, cam, p)


class _Boundary(NamedTuple):
    a: float  # du/dv
    b: float  # u at v = 0
    v_top: float  # highest (smallest v) supported row


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


def _select_side(
    segs: FloatArray, cam: CameraModel, p: HoughParams, *, left: bool
) -> _Boundary | None:
    u0, v0, u1, v1 = segs.T
    du, dv = u1 - u0, v1 - v0
    steep = np.abs(dv) >= p.min_abs_slope * np.abs(du)
    a = np.divide(du, dv, out=np.zeros_like(du), where=dv != 0)
    b = u0 - a * v0
    bottom = float(cam.height - 1)
    u_bottom = a * bottom + b
    cx = cam.intrinsics.cx
    side = (a < 0) & (u_bottom < cx) if left else (a > 0) & (u_bottom > cx)
    u_horizon = a * cam.horizon_row() + b
    converging = np.abs(u_horizon - cx) <= p.vanishing_tolerance * cam.width
    sel = steep & side & converging & (dv != 0)
    if not sel.any():
        return None
    a, b, u_bottom = a[sel], b[sel], u_bottom[sel]
    length = np.hypot(du[sel], dv[sel])
    v_top = np.minimum(v0[sel], v1[sel])
    nearest = int(np.argmin(np.abs(u_bottom - cx)))
    xy, _ = cam.ground_points(np.array([[cx, bottom], [cx + 1.0, bottom]]))
    m_per_px = float(np.hypot(*(xy[1] - xy[0]))) if np.isfinite(xy).all() else 0.01
    cluster = np.abs(u_bottom - u_bottom[nearest]) <= p.cluster_m / max(m_per_px, 1e-6)
    w = length[cluster]
    return _Boundary(
        a=_weighted_median(a[cluster], w),
        b=_weighted_median(b[cluster], w),
        v_top=float(v_top[cluster].min()),
    )


def _weighted_median(values: FloatArray, weights: FloatArray) -> float:
    order = np.argsort(values)
    cum = np.cumsum(weights[order])
    return float(values[order][np.searchsorted(cum, 0.5 * cum[-1])])


def _segment(bound: _Boundary, bottom: float) -> LineSegment:
    return LineSegment(
        bound.a * bottom + bound.b, bottom, bound.a * bound.v_top + bound.b, bound.v_top
    )


def _ground_track(bound: _Boundary, cam: CameraModel) -> tuple[FloatArray, FloatArray]:
    """Return forward and lateral ground coordinates (m) along a boundary, bottom to top."""
    v = np.linspace(cam.height - 1.0, bound.v_top, 64)
    xy, valid = cam.ground_points(np.stack([bound.a * v + bound.b, v], axis=1))
    return xy[valid, 0], xy[valid, 1]


def measure(
    left: _Boundary | None, right: _Boundary | None, cam: CameraModel, p: HoughParams
) -> HoughResult:
    """Turn the selected boundaries into a :class:`HoughResult` with width and range in metres."""
    bottom = cam.height - 1.0
    left_seg = _segment(left, bottom) if left else None
    right_seg = _segment(right, bottom) if right else None
    if left is None or right is None:
        missing = "no left boundary" if left is None else "no right boundary"
        if left is None and right is None:
            missing = "no boundaries"
        return HoughResult(left_seg, right_seg, math.nan, math.nan, False, missing)
    xl, yl = _ground_track(left, cam)
    xr, yr = _ground_track(right, cam)
    if xl.size < 2 or xr.size < 2:
        return HoughResult(left_seg, right_seg, math.nan, math.nan, False, "above the horizon")
    near = p.near_distance_m
    # Boundaries that start beyond the near distance are measured at their nearest point.
    y_left = float(np.interp(near, xl, yl))
    y_right = float(np.interp(near, xr, yr))
    width = y_left - y_right
    reach = float(min(xl.max(), xr.max()))
    if not width > 0:
        return HoughResult(left_seg, right_seg, width, reach, False, "boundaries cross")
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
        raw = detect_ego_lane(image_bgr, cam, self.params)
        self._left = self._blend(self._left, _from_segment(raw.left_line))
        self._right = self._blend(self._right, _from_segment(raw.right_line))
        if raw.left_line is None or raw.right_line is None:
            return raw
        return measure(self._left, self._right, cam, self.params)

    def _blend(self, old: _Boundary | None, new: _Boundary | None) -> _Boundary | None:
        if new is None or old is None or self.alpha >= 1.0:
            return new
        k = self.alpha
        return _Boundary(k * new.a + (1 - k) * old.a, k * new.b + (1 - k) * old.b, new.v_top)


def _from_segment(seg: LineSegment | None) -> _Boundary | None:
    if seg is None or seg.v0 == seg.v1:
        return None
    a = (seg.u1 - seg.u0) / (seg.v1 - seg.v0)
    return _Boundary(a, seg.u0 - a * seg.v0, seg.v1)
