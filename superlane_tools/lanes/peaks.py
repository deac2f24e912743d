"""Lane offsets as peaks of the residual histogram (paper Eq. 4), with sub-bin refinement."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray
from scipy.signal import find_peaks

from superlane_tools.lanes.cost import Histogram, soft_histogram
from superlane_tools.lanes.params import FitParams

FloatArray = NDArray[np.float64]


def find_offsets(residual_m: FloatArray, params: FitParams) -> FloatArray:
    """Return lane offsets (metres, ascending) from the residuals ``y - f(0, a; x)`` of Eq. 4.

    The residuals are soft-binned, summed over a window of ``+-peak_window_m`` (so a peak's
    height counts the points of one line), and peaks are kept when at least
    ``min_peak_separation_m`` apart and at least ``max(min_prominence_fraction * N,
    min_prominence_points)`` prominent. Each offset is then refined to the mean residual of the
    points within the window around its peak.

    Args:
        residual_m: Lane-point residuals, metres (NaN for unusable points).
        params: Fit parameters.
    """
    res = np.asarray(residual_m, dtype=np.float64)
    res = res[np.isfinite(res)]
    if res.size == 0:
        return np.empty(0)
    hist = Histogram.symmetric(params.offset_range_m, params.bin_width_m)
    counts = soft_histogram(res, hist)
    half = max(1, round(params.peak_window_m / hist.width_m))
    box = np.ones(2 * half + 1)
    # Zero padding lets a line sitting at the range edge still be a local maximum.
    window = np.convolve(np.pad(counts, half + 1), box, mode="same")
    prominence = max(params.min_prominence_fraction * res.size, params.min_prominence_points)
    distance = max(1, math.ceil(params.min_peak_separation_m / hist.width_m))
    idx, _ = find_peaks(window, distance=distance, prominence=prominence)
    centres = hist.lo_m + (idx - (half + 1)) * hist.width_m
    offsets = []
    for centre in centres:
        near = res[np.abs(res - centre) <= params.peak_window_m]
        if near.size:
            offsets.append(float(near.mean()))
    out = np.sort(np.asarray(offsets, dtype=np.float64))
    return merge_close(out, params.min_peak_separation_m * 0.5)


def merge_close(offsets: FloatArray, min_gap_m: float) -> FloatArray:
    """Merge offsets closer than ``min_gap_m`` (refinement can pull two peaks together)."""
    if offsets.size < 2:
        return offsets
    keep = [offsets[0]]
    for value in offsets[1:]:
        if value - keep[-1] < min_gap_m:
            keep[-1] = 0.5 * (keep[-1] + value)
        else:
            keep.append(value)
    return np.asarray(keep, dtype=np.float64)


def assign(
    residual_m: FloatArray, offsets: FloatArray, radius_m: FloatArray | float
) -> NDArray[np.intp]:
    """Assign each residual to the nearest offset within ``radius_m`` (else -1).

    Args:
        residual_m: ``(N,)`` residuals, metres (NaN: unassigned).
        offsets: ``(L,)`` lane offsets, metres.
        radius_m: Largest distance to an offset, metres (scalar or per point).
    """
    res = np.asarray(residual_m, dtype=np.float64)
    if offsets.size == 0:
        return np.full(res.shape, -1, dtype=np.intp)
    dist = np.abs(res[:, None] - offsets[None, :])
    dist = np.where(np.isfinite(dist), dist, np.inf)
    label = np.argmin(dist, axis=1)
    best = dist[np.arange(res.size), label]
    out: NDArray[np.intp] = np.where(best <= radius_m, label, -1).astype(np.intp)
    return out
