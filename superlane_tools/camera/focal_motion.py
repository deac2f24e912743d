"""The focal length from the dashed lane markings' motion between frames a known distance apart.

Lane lines alone give the vanishing point in pixels, so without intrinsics the pitch scales
with the assumed focal length. Motion at a known speed fixes it: a road point ``X`` metres ahead
images ``f h / (X cos^2 pitch)`` pixel rows below the horizon (``h`` the camera height), so in
``q = 1 / (rows below the horizon)`` the pattern of dashes along a lane line moves by
``d cos^2(pitch) / (f h)`` between two frames ``d`` metres apart, whatever ``X``. Per frame the
marking pixels along each ego line are sampled on a uniform ``q`` grid (rows rotated back by the
roll); the focal length whose predicted shifts best align all consecutive pairs (correlation
summed over pairs and both lines; solid lines carry no pattern and are left out) is the
estimate. The height and pitch used come from the lane-line estimate, which needs no focal
length for the height and the vanishing row only for the pitch's ``cos^2``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from superlane_tools.camera.extrinsics_estimate import FrameLines, frame_lines
from superlane_tools.camera.model import Extrinsics, Intrinsics

FloatArray = NDArray[np.float64]
ROWS_BELOW_HORIZON = (0.033, 0.33)
"""Rows used, below the horizon, as fractions of the image height (about 60 m to 6 m ahead)."""
Q_SAMPLES = 400
MIN_PAIRS = 8
MIN_DISTANCE_M = 0.3
MAX_DISTANCE_M = 5.0
"""Frame pairs further apart than this could alias the dash pattern (3 m dashes, 9 m gaps)."""
MIN_PATTERN_STD = 0.2
"""A line whose samples vary less than this (a solid line, no line) has no pattern to follow."""
MIN_MEAN_CORRELATION = 0.3


@dataclass(frozen=True)
class FocalEstimate:
    """A focal length measured from motion.

    Attributes:
        focal_px: Focal length, pixels.
        pairs: Line profiles (frame pairs x dashed sides) that were aligned.
        mean_correlation: Mean correlation of the aligned profiles at ``focal_px`` (0-1).
    """

    focal_px: float
    pairs: int
    mean_correlation: float


def _q_grid(height_px: int) -> FloatArray:
    lo, hi = ROWS_BELOW_HORIZON
    return np.linspace(1.0 / (hi * height_px), 1.0 / (lo * height_px), Q_SAMPLES)


def dash_profiles(
    uv: FloatArray, lines: FrameLines, intrinsics: Intrinsics, extrinsics: Extrinsics
) -> list[FloatArray]:
    """Return the marking presence along the left and right line on the ``q`` grid.

    Args:
        uv: Lane-marking pixels ``(N, 2)`` of the frame.
        lines: The frame's ego lines (normalised coordinates of ``intrinsics``).
        intrinsics: The intrinsics the lines were fitted with (any focal length: the pixel
            lines and the horizon row do not depend on it).
        extrinsics: Pitch and roll of the lane-line estimate.

    Returns:
        Two arrays of :data:`Q_SAMPLES` values in 0-1, NaN outside the image.
    """
    k = intrinsics
    mask = np.zeros((k.height, k.width), dtype=bool)
    cols = np.clip(uv[:, 0].astype(int), 0, k.width - 1)
    rows = np.clip(uv[:, 1].astype(int), 0, k.height - 1)
    mask[rows, cols] = True
    c, s = math.cos(extrinsics.roll_rad), math.sin(extrinsics.roll_rad)
    horizon = k.cy - k.fy * math.tan(extrinsics.pitch_rad)  # in the image rotated back by roll
    grid = _q_grid(k.height)
    v = np.arange(k.height, dtype=np.float64)
    out = []
    for a, b in (lines.left, lines.right):
        u = np.round((a * (v - k.cy) / k.fy + b) * k.fx + k.cx).astype(int)
        ok = (u >= 1) & (u < k.width - 1)
        hit = np.zeros(k.height)
        r = v.astype(int)[ok]
        hit[ok] = mask[r, u[ok]] | mask[r, u[ok] - 1] | mask[r, u[ok] + 1]
        v0 = k.cy + s * (u - k.cx) * k.fy / k.fx + c * (v - k.cy)
        keep = ok & (v0 > horizon + 1.0)
        q = 1.0 / (v0[keep] - horizon)
        order = np.argsort(q)
        out.append(np.interp(grid, q[order], hit[keep][order], left=np.nan, right=np.nan))
    return out


def focal_from_motion(
    pairs: Sequence[tuple[Sequence[FloatArray], Sequence[FloatArray], float]],
    extrinsics: Extrinsics,
    width_px: int,
    height_px: int,
) -> FocalEstimate | None:
    """Return the focal length that best aligns consecutive frames' dash patterns.

    Args:
        pairs: ``(profiles of frame a, profiles of frame b, metres driven from a to b)``.
        extrinsics: Pitch and height of the lane-line estimate.
        width_px: Image width; focal lengths of 0.3-3 widths (fields of view of 19-118 degrees)
            are searched.
        height_px: Image height (the ``q`` grid).

    Returns:
        The estimate, or None with fewer than :data:`MIN_PAIRS` usable profile pairs or no
        clear alignment.
    """
    grid = _q_grid(height_px)
    used = [
        (d, p0, p1)
        for a, b, d in pairs
        if MIN_DISTANCE_M <= d <= MAX_DISTANCE_M
        for p0, p1 in zip(a, b, strict=True)
        if np.nanstd(p0) >= MIN_PATTERN_STD and np.nanstd(p1) >= MIN_PATTERN_STD
    ]
    if len(used) < MIN_PAIRS:
        return None
    scale = math.cos(extrinsics.pitch_rad) ** 2 / extrinsics.height_m
    focals = np.geomspace(0.3 * width_px, 3.0 * width_px, 800)
    scores = np.zeros(focals.size)
    for i, f in enumerate(focals):
        total = 0.0
        for d, p0, p1 in used:
            moved = np.interp(grid + d * scale / f, grid, p0, left=np.nan, right=np.nan)
            ok = ~np.isnan(moved) & ~np.isnan(p1)
            if ok.sum() < Q_SAMPLES // 8:
                continue
            x, y = p1[ok] - p1[ok].mean(), moved[ok] - moved[ok].mean()
            norm = math.sqrt(float((x * x).sum() * (y * y).sum()))
            if norm > 0.0:
                total += float((x * y).sum()) / norm
        scores[i] = total
    best = int(np.argmax(scores))
    mean = float(scores[best]) / len(used)
    if mean < MIN_MEAN_CORRELATION or best in (0, focals.size - 1):
        return None
    return FocalEstimate(float(focals[best]), len(used), mean)


class SampledLines(NamedTuple):
    """A segmented frame: its index, log time and lane-marking pixels ``(u, v)``."""

    frame: int
    log_time_ns: int | None
    uv: NDArray[np.float64]


Track = tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]
"""A GNSS track: log time ns, east m, north m."""


def too_far(track: Track | None, t0: int | None, t1: int | None) -> bool:
    """Return True when the GNSS track puts two frame times too far apart to follow a dash."""
    if track is None or t0 is None or t1 is None:
        return True
    times, east, north = track
    t = np.asarray([t0, t1], dtype=np.float64)
    de = np.diff(np.interp(t, times, east))[0]
    dn = np.diff(np.interp(t, times, north))[0]
    return bool(np.hypot(de, dn) > MAX_DISTANCE_M)


def focal_from_frame_pairs(
    sampled: list[SampledLines],
    lines: list[FrameLines | None],
    successors: dict[int, SampledLines],
    track: Track,
    k: Intrinsics,
    extrinsics: Extrinsics,
) -> FocalEstimate | str:
    """Return the focal length from the dashes' motion, or why it could not be measured."""
    times, east, north = track
    pairs = []
    for item, fl in zip(sampled, lines, strict=True):
        nxt = successors.get(item.frame)
        if fl is None or nxt is None or item.log_time_ns is None or nxt.log_time_ns is None:
            continue
        fl2 = frame_lines(nxt.uv, k, seed=nxt.frame)
        if fl2 is None:
            continue
        t = np.asarray([item.log_time_ns, nxt.log_time_ns], dtype=np.float64)
        if t[0] < times[0] or t[1] > times[-1]:
            continue
        de, dn = np.diff(np.interp(t, times, east))[0], np.diff(np.interp(t, times, north))[0]
        d = float(np.hypot(de, dn))
        pairs.append(
            (
                dash_profiles(item.uv, fl, k, extrinsics),
                dash_profiles(nxt.uv, fl2, k, extrinsics),
                d,
            )
        )
    if not pairs:
        return "no consecutive frames with both ego lines inside the GNSS track"
    moved = [d for _, _, d in pairs if MIN_DISTANCE_M <= d <= MAX_DISTANCE_M]
    if not moved:
        median = float(np.median([d for _, _, d in pairs]))
        return (
            f"consecutive frames {median:.1f} m apart; needs {MIN_DISTANCE_M:g}-"
            f"{MAX_DISTANCE_M:g} m (a higher frame rate or a slower drive)"
        )
    found = focal_from_motion(pairs, extrinsics, k.width, k.height)
    if found is None:
        return f"{len(pairs)} frame pairs, no clear dash pattern alignment"
    return found
