"""Fitted lanes back into the image: pixel columns at given rows, inside each lane's range."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from superlane_tools.camera.model import CameraModel
from superlane_tools.lanes.result import Lane

FloatArray = NDArray[np.float64]

N_SAMPLES = 256
"""Samples along a lane's range; spaced uniformly in ``1/x`` (about uniformly in image rows)."""


def lane_polyline(
    lane: Lane,
    slope: float,
    camera: CameraModel,
    n_samples: int = N_SAMPLES,
    vertical_curvature: float = 0.0,
) -> FloatArray:
    """Return ``(n, 2)`` image pixels ``(u, v)`` along the lane's supported range.

    The lane lies on the road ``z = slope * x + vertical_curvature * x**2`` (x from the camera
    foot), i.e. the inverse of the slope-compensated IPM. Samples behind the camera are dropped.

    Args:
        lane: A fitted lane.
        slope: The frame's road slope ``b`` (rise over run).
        camera: The camera of the frame.
        n_samples: Number of samples between ``range_min_m`` and ``range_max_m``.
        vertical_curvature: The frame's vertical curvature term ``c`` (1/m, ``LaneFit.c``).
    """
    lo = max(lane.range_min_m, 1e-3)
    hi = max(lane.range_max_m, lo)
    inv = np.linspace(1.0 / lo, 1.0 / hi, n_samples)
    x = 1.0 / inv
    ext = camera.extrinsics
    pts = np.stack(
        [
            ext.x_m + x,
            ext.y_m + lane.offset_m + x * (lane.a1 + lane.a2 * x),
            x * (slope + vertical_curvature * x),
        ],
        axis=1,
    )
    uv, front = camera.project(pts)
    out: FloatArray = uv[front]
    return out


def columns_at_rows(
    lane: Lane,
    slope: float,
    camera: CameraModel,
    rows_px: FloatArray,
    vertical_curvature: float = 0.0,
) -> FloatArray:
    """Return the lane's image column at each row (pixels), NaN outside its supported range.

    For each row, finds the forward distance whose projection lies on that row (by interpolation
    along a dense polyline, exact to well under a pixel) and returns its column. Rows above the
    lane's farthest supported point or below its nearest one are NaN, so an exported lane starts
    and ends where its pixels do.

    Args:
        lane: A fitted lane.
        slope: The frame's road slope ``b``.
        camera: The camera of the frame.
        rows_px: Image rows, pixels.
        vertical_curvature: The frame's vertical curvature term ``c`` (1/m, ``LaneFit.c``).
    """
    rows = np.asarray(rows_px, dtype=np.float64)
    out = np.full(rows.shape, np.nan)
    poly = lane_polyline(lane, slope, camera, vertical_curvature=vertical_curvature)
    if poly.shape[0] < 2:
        return out
    v, u = poly[:, 1], poly[:, 0]
    order = np.argsort(v)
    v, u = v[order], u[order]
    # Half a pixel of slack: the range ends are pixel centres, the rows are integers.
    inside = (rows >= v[0] - 0.5) & (rows <= v[-1] + 0.5)
    out[inside] = np.interp(rows[inside], v, u)
    return out


def lanes_at_rows(
    lanes: tuple[Lane, ...] | list[Lane],
    slope: float,
    camera: CameraModel,
    rows_px: FloatArray,
    vertical_curvature: float = 0.0,
) -> FloatArray:
    """Return ``(L, R)`` image columns of every lane at every row (NaN outside each range)."""
    if not lanes:
        return np.empty((0, np.asarray(rows_px).size))
    return np.stack(
        [columns_at_rows(ln, slope, camera, rows_px, vertical_curvature) for ln in lanes]
    )
