"""Training targets from TuSimple lane labels: paint-width markings, the road, the ego lane.

TuSimple labels each lane line as x positions at fixed image rows (``h_samples``; ``-2`` = no
point). Rasterised here, at any target size:

* **markings** (node ``lane_marking``, type unknown): each polyline drawn with the width real paint
  has in the image, which grows linearly towards the bottom. The width comes from the labels
  themselves: the gaps between neighbouring lines at each row are lane widths (about
  ``LANE_WIDTH_M``), so ``MARKING_WIDTH_M / LANE_WIDTH_M`` of the gap is the paint width;
* **road** (node ``road``): the area between the outermost lines of every row;
* **ego lane** (corridor target): the area between the lines left and right of the image centre
  at the bottom, from the highest row both are labelled down to the bottom; rows above it are
  unknown (``CORRIDOR_IGNORE``).

Pixels outside the road stay void: TuSimple does not say what they are. Optionally
(``expand_m``) a band on each side of every marking becomes road too, as the SUPER paper does for
Apollo's marking labels (II-B); TuSimple has no occluder labels, so unlike the paper's Apollo
preprocessing a vehicle beside a marking is not cut out of that band.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from superlane_tools.scene.adapters.heads import NODE_CODES

LANE_WIDTH_M = 3.7
MARKING_WIDTH_M = 0.15
MIN_MARKING_PX = 1.5
CORRIDOR_IGNORE = 255

Polyline = NDArray[np.float64]
"""``(K, 2)`` array of ``(x, y)`` pixel positions, top to bottom."""


def label_polylines(label: dict[str, Any], scale_x: float, scale_y: float) -> list[Polyline]:
    """Return each labelled lane of a TuSimple label line as a polyline scaled to the target."""
    rows = label["h_samples"]
    lines: list[Polyline] = []
    for lane in label["lanes"]:
        pts = [(x * scale_x, y * scale_y) for x, y in zip(lane, rows, strict=True) if x >= 0]
        if len(pts) >= 2:
            lines.append(np.array(sorted(pts, key=lambda p: p[1]), dtype=np.float64))
    return lines


def _x_at(line: Polyline, y: float) -> float | None:
    if not line[0, 1] <= y <= line[-1, 1]:
        return None
    return float(np.interp(y, line[:, 1], line[:, 0]))


def gap_model(lines: Sequence[Polyline], height: int) -> tuple[float, float]:
    """Return ``(a, b)`` of the lane width in pixels, ``gap(y) = a * y + b``, fitted to the labels.

    Falls back to a lane that is half the image height wide at the bottom row and zero at 40 %
    of the height (a typical forward camera) when fewer than three gaps are labelled.
    """
    ys, gaps = [], []
    if lines:
        for y in np.unique(np.concatenate([line[:, 1] for line in lines])):
            xs = sorted(x for line in lines if (x := _x_at(line, float(y))) is not None)
            for left, right in itertools.pairwise(xs):
                ys.append(float(y))
                gaps.append(right - left)
    if len(gaps) >= 3 and np.ptp(ys) > 0:
        a, b = np.polyfit(ys, gaps, 1)
        if a > 0:
            return float(a), float(b)
    a = 0.5 * height / (0.6 * height)
    return a, -a * 0.4 * height


def draw_markings(
    canvas: NDArray[np.uint8],
    lines: Sequence[Polyline],
    value: int,
    gap: tuple[float, float],
    width_m: float = MARKING_WIDTH_M,
) -> None:
    """Draw every polyline into ``canvas``, ``width_m`` wide: ``width_m / LANE_WIDTH_M`` of the gap.

    The default is the paint's width; at least :data:`MIN_MARKING_PX` at any row.
    """
    import cv2

    a, b = gap
    ratio = width_m / LANE_WIDTH_M
    for line in lines:
        half = np.maximum(MIN_MARKING_PX, ratio * (a * line[:, 1] + b)) / 2.0
        for (x0, y0), (x1, y1), h0, h1 in zip(
            line[:-1], line[1:], half[:-1], half[1:], strict=True
        ):
            quad = np.array([[x0 - h0, y0], [x0 + h0, y0], [x1 + h1, y1], [x1 - h1, y1]])
            cv2.fillConvexPoly(canvas, np.round(quad * 16).astype(np.int32), value, cv2.LINE_8, 4)


def _between(
    left: Sequence[tuple[float, float]], right: Sequence[tuple[float, float]]
) -> NDArray[np.int32]:
    pts = [*left, *reversed(right)]
    return np.round(np.array(pts) * 16).astype(np.int32)


def road_and_marking_codes(
    lines: Sequence[Polyline], width: int, height: int, expand_m: float = 0.0
) -> NDArray[np.uint8]:
    """Return ``(H, W)`` node codes: road between the outer lines, markings on top, else void.

    ``expand_m > 0`` also labels a band ``expand_m`` wide on each side of every marking as road
    (SUPER II-B's preprocessing of Apollo's marking labels: the ground next to a marking is
    often mistaken for it), which reaches beyond the outer lines onto the shoulder.
    """
    import cv2

    codes = np.zeros((height, width), np.uint8)
    if not lines:
        return codes
    gap = gap_model(lines, height)
    if expand_m > 0:
        draw_markings(codes, lines, NODE_CODES["road"], gap, MARKING_WIDTH_M + 2.0 * expand_m)
    left: list[tuple[float, float]] = []
    right: list[tuple[float, float]] = []
    for y in np.unique(np.concatenate([line[:, 1] for line in lines])):
        xs = [x for line in lines if (x := _x_at(line, float(y))) is not None]
        if len(xs) >= 2:
            left.append((min(xs), float(y)))
            right.append((max(xs), float(y)))
    if len(left) >= 2:
        cv2.fillPoly(codes, [_between(left, right)], NODE_CODES["road"], cv2.LINE_8, 4)
    draw_markings(codes, lines, NODE_CODES["lane_marking"], gap)
    return codes


def _bottom_x(line: Polyline, height: int) -> float:
    tail = line[-3:]
    if np.ptp(tail[:, 1]) <= 0:
        return float(tail[-1, 0])
    slope, offset = np.polyfit(tail[:, 1], tail[:, 0], 1)
    return float(slope * height + offset)


def ego_lines(
    lines: Sequence[Polyline], width: int, height: int
) -> tuple[Polyline, Polyline] | None:
    """Return the (left, right) lines around the image centre at the bottom, or None."""
    centre = width / 2.0
    at_bottom = [(_bottom_x(line, height), i) for i, line in enumerate(lines)]
    lefts = [(x, i) for x, i in at_bottom if x < centre]
    rights = [(x, i) for x, i in at_bottom if x >= centre]
    if not lefts or not rights:
        return None
    return lines[max(lefts)[1]], lines[min(rights)[1]]


def corridor_target(lines: Sequence[Polyline], width: int, height: int) -> NDArray[np.uint8]:
    """Return the ego-lane target: 1 inside, 0 outside, ``CORRIDOR_IGNORE`` above the labels."""
    import cv2

    target = np.full((height, width), CORRIDOR_IGNORE, np.uint8)
    pair = ego_lines(lines, width, height)
    if pair is None:
        return target
    left, right = pair
    top = max(left[0, 1], right[0, 1])
    rows = [float(y) for y in np.unique(np.concatenate([left[:, 1], right[:, 1]])) if y >= top]
    lx = [(x, y) for y in rows if (x := _x_at(left, y)) is not None]
    rx = [(x, y) for y in rows if (x := _x_at(right, y)) is not None]
    if len(lx) < 2 or len(rx) < 2:
        return target
    lx.append((_bottom_x(left, height), float(height)))
    rx.append((_bottom_x(right, height), float(height)))
    target[int(np.ceil(top)) :] = 0
    cv2.fillPoly(target, [_between(lx, rx)], 1, cv2.LINE_8, 4)
    return target
