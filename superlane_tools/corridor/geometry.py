"""Ego-corridor geometry in metres: width and length from a corridor mask or from fitted lanes.

The corridor is the drivable part of the ego lane ahead (up to the preceding vehicle). Its
geometry feeds the availability KPI (corridor paper, section IV-B):

* **width (m)**: the lateral extent of the corridor (leftmost to rightmost corridor pixel, through
  the camera's inverse perspective mapping) at the forward distance ``width_at_m`` (default
  10 m), the median over the image rows within ``width_band_m`` of it; where the corridor ends
  nearer (length < ``width_at_m``), at its far end. Every method of the availability KPI
  measures its width at the same distance by this rule (:func:`width_distance`);
* **length (m)**: the forward distance of the far end of the *contiguous full-width* corridor:
  walking up the image from the nearest row, rows count while the corridor spans at least
  ``full_width_fraction`` of that width (and ``min_row_px`` pixels), and the walk stops at the first
  run of more than ``max_gap_rows`` rows that do not. The tapering tip of a network's mask and
  stray far blobs thus do not count: a pointed tip of a few pixels near the horizon maps to tens
  of metres on the flat ground, and on simulated drives it overstated the length by 12-15 m
  against the ground-truth gap to the preceding vehicle. (The farthest supported row, or a
  percentile of row distances, is biased long or short: rows are dense near the camera.)

**Measurable range.** Far up the image one row spans metres of ground: a row ``x`` metres ahead
spans about ``x^2 / (f h)`` (focal length ``f`` px, camera height ``h`` m), so a length read there
is a guess, and a network's mask reaching into the horizon rows gave corridors of kilometres on a
real dashcam clip. Every corridor length is capped at the camera's measurable range
(:func:`measurable_range_m`): the farthest flat-ground distance, straight ahead at the processing
size, at which one image row spans at most ``max_row_step`` (10 %) of the distance; about
``0.1 f h``, 75 m for a 640 px wide image with a 65 degree lens at 1.5 m.

Distances are forward distances from the origin of the camera's vehicle frame (ISO 8855: the
road point below the vehicle reference point; the camera foot with the default extrinsics), the
same origin for every method's length and width distance.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from functools import lru_cache
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from superlane_tools.camera.model import CameraModel
from superlane_tools.corridor.errors import CorridorError

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class CorridorParams:
    """How corridor width and length are measured.

    Attributes:
        threshold: Probability above which a pixel belongs to the corridor.
        width_at_m: Forward distance at which the width is measured, metres (from the
            vehicle-frame origin; at the corridor's far end when it is shorter).
        width_band_m: Rows within this forward distance of ``width_at_m`` give the width (their
            median), metres.
        min_row_px: Smallest number of corridor pixels for a row to count as support.
        full_width_fraction: A row counts towards the length while its lateral extent is at least
            this fraction of the corridor width.
        max_gap_rows: Longest run of rows below that width bridged by the length walk.
        max_row_step: Lengths are capped where one image row spans more than this fraction of
            the distance (:func:`measurable_range_m`); 0 turns the cap off.
    """

    threshold: float = 0.5
    width_at_m: float = 10.0
    width_band_m: float = 1.0
    min_row_px: int = 3
    full_width_fraction: float = 0.8
    max_gap_rows: int = 2
    max_row_step: float = 0.1


MAX_ROW_STEP = 0.1
"""Default cap of corridor lengths: one image row may span at most 10 % of the distance."""


@lru_cache(maxsize=8)
def measurable_range_m(camera: CameraModel, max_row_step: float = MAX_ROW_STEP) -> float:
    """Return the farthest forward distance (m) a length can be measured at with ``camera``.

    Straight ahead (the image's centre column), on the flat ground: the farthest row whose
    step to the next nearer row is at most ``max_row_step`` times its distance. Infinite when
    ``max_row_step`` is 0 (no cap); NaN when no row sees the ground.
    """
    if max_row_step <= 0:
        return math.inf
    rows = np.arange(camera.height, dtype=np.float64)
    uv = np.stack([np.full(rows.size, (camera.width - 1) / 2.0), rows], axis=1)
    xy, valid = camera.ground_points(uv)
    x = np.where(np.asarray(valid, dtype=bool), xy[:, 0], np.nan)
    far, near = x[:-1], x[1:]  # row v and the row below it
    with np.errstate(invalid="ignore"):
        ok = np.isfinite(far) & np.isfinite(near) & (far - near <= max_row_step * far) & (far > 0)
    return float(far[ok].max()) if ok.any() else math.nan


class CorridorGeometry(NamedTuple):
    """Width and length of the ego corridor.

    Attributes:
        width_m: Lateral width, metres (NaN when not measurable).
        length_m: Forward length from the camera, metres (NaN when there is no corridor).
        n_rows: Image rows with corridor support (0 for lane-based geometry).
    """

    width_m: float
    length_m: float
    n_rows: int


NO_CORRIDOR = CorridorGeometry(math.nan, math.nan, 0)


def corridor_from_mask(
    probability: NDArray[np.floating] | NDArray[np.bool_] | NDArray[np.uint8],
    camera: CameraModel,
    params: CorridorParams | None = None,
) -> CorridorGeometry:
    """Measure the corridor in a per-pixel probability or mask image.

    Args:
        probability: ``(H, W)`` corridor probability in ``[0, 1]`` or a boolean / 0-1 mask, at
            any resolution (the camera is resized to it).
        camera: Camera of the image.
        params: Measurement parameters.

    Raises:
        CorridorError: If the array is not two-dimensional.
    """
    p = params or CorridorParams()
    prob = np.asarray(probability)
    if prob.ndim != 2:
        raise CorridorError(f"corridor probability must be (H, W), got shape {prob.shape}")
    height, width = prob.shape
    cam = (
        camera
        if (camera.width, camera.height) == (width, height)
        else camera.resized(width, height)
    )
    mask = prob > p.threshold if prob.dtype != np.bool_ else prob
    ground_x, ground_y, valid = _ground_grid(cam)
    mask = mask & valid
    count = np.count_nonzero(mask, axis=1)
    if not count.any():
        return NO_CORRIDOR
    safe = np.maximum(count, 1)
    x_row = np.where(mask, ground_x, 0.0).sum(axis=1) / safe
    y_min = np.where(mask, ground_y, np.inf).min(axis=1)
    y_max = np.where(mask, ground_y, -np.inf).max(axis=1)
    support = count >= p.min_row_px
    if not support.any():
        return NO_CORRIDOR
    row_width = np.where(support, y_max - y_min, 0.0)
    in_band = support & (np.abs(x_row - p.width_at_m) <= p.width_band_m)
    reference = float(np.median(row_width[in_band if in_band.any() else support]))
    length = _full_width_length(x_row, row_width, support, reference, p)
    cap = measurable_range_m(cam, p.max_row_step)
    if math.isfinite(cap):
        length = min(length, cap)
    at = width_distance(p.width_at_m, length)
    rows = support & (np.abs(x_row - at) <= p.width_band_m) & (x_row <= length + 1e-9)
    if not rows.any():  # sparse rows far ahead: the supported row nearest to the distance
        rows = np.zeros_like(support)
        rows[np.flatnonzero(support)[np.argmin(np.abs(x_row[support] - at))]] = True
    return CorridorGeometry(float(np.median(row_width[rows])), length, int(support.sum()))


def width_distance(width_at_m: float, length_m: float) -> float:
    """Return where a corridor's width is measured: ``width_at_m`` ahead, or its far end if nearer.

    Args:
        width_at_m: The configured width distance, metres ahead of the vehicle-frame origin.
        length_m: The corridor's length from the same origin, metres (NaN: unknown, then
            ``width_at_m``).
    """
    return float(min(width_at_m, length_m)) if math.isfinite(length_m) else float(width_at_m)


def _full_width_length(
    x_row: FloatArray,
    row_width: FloatArray,
    support: NDArray[np.bool_],
    reference_m: float,
    p: CorridorParams,
) -> float:
    """Return the forward distance (m) of the far end of the contiguous full-width corridor."""
    full = np.flatnonzero(support & (row_width >= p.full_width_fraction * reference_m))
    if full.size == 0:
        # Degenerate masks (no row reaches the reference width): the nearest supported row.
        return float(x_row[np.flatnonzero(support)[-1]])
    near_to_far = full[::-1]  # image rows, bottom (near) first
    breaks = np.flatnonzero(near_to_far[:-1] - near_to_far[1:] > p.max_gap_rows + 1)
    end = int(near_to_far[breaks[0]]) if breaks.size else int(near_to_far[-1])
    return float(x_row[end])


@lru_cache(maxsize=8)
def _ground_grid(camera: CameraModel) -> tuple[FloatArray, FloatArray, NDArray[np.bool_]]:
    """Return the flat-ground ``x`` and ``y`` (metres) of every pixel and where they are valid.

    Computed once per camera (and image size) and reused for every frame: the per-pixel inverse
    perspective mapping dominated the cost of measuring a mask. Invalid pixels (at or above the
    horizon) hold 0.
    """
    height, width = camera.height, camera.width
    rows, cols = np.mgrid[0:height, 0:width]
    uv = np.stack([cols.ravel(), rows.ravel()], axis=1).astype(np.float64)
    xy, valid = camera.ground_points(uv)
    xy = np.where(valid[:, None], xy, 0.0)
    ground_x = np.ascontiguousarray(xy[:, 0].reshape(height, width))
    ground_y = np.ascontiguousarray(xy[:, 1].reshape(height, width))
    for array in (ground_x, ground_y):
        array.flags.writeable = False
    ok = np.asarray(valid, dtype=bool).reshape(height, width)
    ok.flags.writeable = False
    return ground_x, ground_y, ok


Line = float | Sequence[float] | None
"""A lane boundary ``y(x) = c0 + c1 x + c2 x^2 + ...`` (metres, left positive): its coefficients
low order first, one offset (a line parallel to ``x``), or None (missing)."""


def corridor_from_lanes(
    left: Line,
    right: Line,
    range_m: float | None,
    width_at_m: float = 10.0,
    x_origin_m: float = 0.0,
) -> CorridorGeometry:
    """Corridor geometry from fitted ego boundaries: width between them, length = view range.

    Args:
        left: The ego lane's left boundary.
        right: The ego lane's right boundary.
        range_m: Forward view range of the lines, metres from the lines' own origin.
        width_at_m: Forward distance of the width, metres from the vehicle-frame origin (at the
            corridor's far end when it is shorter, :func:`width_distance`).
        x_origin_m: Forward position of the lines' origin in the vehicle frame, metres (e.g.
            the camera foot's, for lines fitted from the camera foot).

    Returns:
        Width ``left(x) - right(x)`` at the width distance (NaN if a boundary is missing) and
        length ``range_m + x_origin_m``.
    """
    length = math.nan if range_m is None else float(range_m) + x_origin_m
    if left is None or right is None:
        return CorridorGeometry(math.nan, length, 0)
    x = width_distance(width_at_m, length) - x_origin_m
    width = _polyval(left, x) - _polyval(right, x)
    return CorridorGeometry(width, length, 0)


def _polyval(line: float | Sequence[float], x_m: float) -> float:
    """Evaluate a boundary; a missing higher coefficient (NaN) counts as 0, a missing offset not."""
    coeffs = np.atleast_1d(np.asarray(line, dtype=np.float64))
    higher = np.nan_to_num(coeffs[1:])
    return float(coeffs[0] + np.polynomial.polynomial.polyval(x_m, np.concatenate(([0.0], higher))))
