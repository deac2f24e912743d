"""SUPER curvature referred to the vehicle's position, comparable with RTK path curvature.

The SUPER fit's ``2*a2`` is the curvature of a quadratic fitted to the lane lines over its
supported range ahead of the camera, so on a clothoid road it equals the road curvature at
the middle of that range (for a least-squares quadratic over ``[x0, x1]``, the cubic term of a
clothoid moves ``2*a2`` by ``dkappa/ds * (x0 + x1) / 2``). RTK curvature is the curvature of the
vehicle's own path *at* the vehicle, and it includes lateral manoeuvres inside the lane and lane
changes, which the road curvature does not. :func:`align_super_curvature` makes the two
comparable, in three documented steps, all on the RTK arc length ``s`` (metres):

1. **Look-ahead.** Each frame's ``2*a2`` is placed at ``s + lookahead`` (the middle of the
   fit's supported range) and interpolated back at the frames' own ``s``: the road curvature
   where the vehicle is.
2. **Same low-pass as the truth.** Both the road curvature and the vehicle's lateral position in
   its lane are resampled every ``ds_m`` and smoothed with the Savitzky-Golay filter the RTK
   truth uses (order 3, ``window_m``).
3. **Lateral manoeuvres.** The vehicle's lateral position on the lane grid ``l(s)`` (minus the
   lane-centre offset, which the pipeline takes as the circular mean of all fitted line offsets
   with period one lane width, unwrapped at lane changes) is measured by the same fit; for
   small angles the path curvature is ``kappa_road(s) + l''(s)``.

Nothing here reads files: arrays in, arrays out.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray
from scipy.signal import savgol_filter

FloatArray = NDArray[np.float64]


class AlignedCurvature(NamedTuple):
    """SUPER curvature at the vehicle, per frame (NaN where it cannot be formed).

    Attributes:
        road_per_m: Road curvature at the vehicle from ``2*a2`` placed at its look-ahead and
            smoothed like the truth, 1/m, left positive.
        lateral_per_m: Lateral-manoeuvre term ``l''(s)`` from the fitted lane offsets, 1/m.
        path_per_m: ``road_per_m + lateral_per_m``: the vehicle's path curvature, 1/m.
        lateral_m: Vehicle position left of the ego lane centre, unwrapped, metres.
    """

    road_per_m: FloatArray
    lateral_per_m: FloatArray
    path_per_m: FloatArray
    lateral_m: FloatArray


def lateral_in_lane(centre_m: FloatArray, lane_width_m: FloatArray) -> FloatArray:
    """Return the vehicle's lateral position left of its lane centre, unwrapped, metres.

    Args:
        centre_m: Ego lane centre offset in the vehicle frame per frame, metres (left positive;
            NaN where the fit has no ego lane).
        lane_width_m: Ego lane width per frame, metres.

    Returns:
        ``-centre`` plus a whole number of lane widths chosen so that the position moves
        continuously across ego-lane changes (a lane change to the left makes the centre jump
        right by one lane width).
    """
    centre = np.asarray(centre_m, dtype=np.float64)
    width = np.asarray(lane_width_m, dtype=np.float64)
    out = np.full(centre.shape, np.nan)
    shift, last = 0.0, np.nan
    for k, c in enumerate(centre):
        if not np.isfinite(c):
            continue
        w = width[k] if np.isfinite(width[k]) and width[k] > 1.0 else 3.5
        if np.isfinite(last):
            jump = c - last
            if abs(jump) > 0.5 * w:
                shift += round(jump / w) * w
        last = c
        out[k] = -(c - shift)
    return out


def _blocks(s_m: FloatArray, max_gap_m: float) -> list[NDArray[np.intp]]:
    """Split frame indices into runs of finite, increasing ``s`` without gaps over max_gap_m."""
    idx = np.flatnonzero(np.isfinite(s_m))
    if idx.size == 0:
        return []
    s = s_m[idx]
    cut = np.flatnonzero((np.diff(s) <= -1e-6) | (np.diff(s) > max_gap_m)) + 1
    return [b for b in np.split(idx, cut) if b.size >= 2]


def _smooth_on_s(
    s: FloatArray, value: FloatArray, ds_m: float, window_m: float, deriv: int
) -> FloatArray:
    """Savitzky-Golay smooth (or differentiate) ``value(s)`` on a uniform grid; back at ``s``."""
    ok = np.isfinite(value)
    out = np.full(s.shape, np.nan)
    if ok.sum() < 2:
        return out
    s_ok, v_ok = s[ok], value[ok]
    order = np.argsort(s_ok, kind="stable")
    s_ok, v_ok = s_ok[order], v_ok[order]
    grid = np.arange(s_ok[0], s_ok[-1] + 0.5 * ds_m, ds_m)
    window = round(window_m / ds_m) | 1
    if grid.size < window or window <= 3:
        return out
    resampled = np.interp(grid, s_ok, v_ok)
    smooth = savgol_filter(resampled, window, 3, deriv=deriv, delta=ds_m)
    half = 0.5 * window_m
    inside = (s >= s_ok[0] + half) & (s <= s_ok[-1] - half)
    out[inside] = np.interp(s[inside], grid, smooth)
    return out


def align_super_curvature(
    s_m: FloatArray,
    curvature_per_m: FloatArray,
    lookahead_m: FloatArray,
    centre_m: FloatArray,
    lane_width_m: FloatArray,
    window_m: float = 30.0,
    ds_m: float = 0.5,
    max_gap_m: float = 15.0,
) -> AlignedCurvature:
    """Refer SUPER's ``2*a2`` to the vehicle position and add the lateral-manoeuvre term.

    Args:
        s_m: RTK arc length at each frame, metres (NaN without truth).
        curvature_per_m: SUPER ``2*a2`` per frame, 1/m (NaN where the fit failed).
        lookahead_m: Distance ahead of the vehicle each frame's ``2*a2`` describes, metres.
        centre_m: Ego lane centre offset per frame (vehicle frame, left positive), metres.
        lane_width_m: Ego lane width per frame, metres.
        window_m: Savitzky-Golay window, metres (the RTK truth's).
        ds_m: Resampling step, metres.
        max_gap_m: Frames more than this apart along ``s`` are not bridged, metres.

    Returns:
        Road, lateral and path curvature at each frame (1/m) and the lateral position (m).
    """
    s = np.asarray(s_m, dtype=np.float64)
    curv = np.asarray(curvature_per_m, dtype=np.float64)
    ahead = np.asarray(lookahead_m, dtype=np.float64)
    lateral = lateral_in_lane(centre_m, lane_width_m)
    road_at_vehicle = np.full(s.shape, np.nan)
    for block in _blocks(s, max_gap_m):
        sb = s[block]
        placed = sb + np.where(np.isfinite(ahead[block]), ahead[block], np.nan)
        ok = np.isfinite(placed) & np.isfinite(curv[block])
        if ok.sum() >= 2:
            order = np.argsort(placed[ok], kind="stable")
            xp, fp = placed[ok][order], curv[block][ok][order]
            within = (sb >= xp[0]) & (sb <= xp[-1])
            road_at_vehicle[block[within]] = np.interp(sb[within], xp, fp)
    road = _smooth_blocks(s, road_at_vehicle, ds_m, window_m, max_gap_m, 0)
    lat_term = _smooth_blocks(s, lateral, ds_m, window_m, max_gap_m, 2)
    return AlignedCurvature(road, lat_term, road + lat_term, lateral)


def _smooth_blocks(
    s: FloatArray, v: FloatArray, ds_m: float, window_m: float, max_gap_m: float, deriv: int
) -> FloatArray:
    """Smooth (or differentiate) ``v`` along ``s`` run by run, NaN where ``v`` was NaN."""
    out = np.full(s.shape, np.nan)
    for block in _blocks(s, max_gap_m):
        out[block] = _smooth_on_s(s[block], v[block], ds_m, window_m, deriv)
        # The smoothed value is only trusted where the raw one existed (no filling of gaps).
        out[block[~np.isfinite(v[block])]] = np.nan
    return out


def smooth_like_truth(
    s_m: FloatArray,
    value: FloatArray,
    window_m: float = 30.0,
    ds_m: float = 0.5,
    max_gap_m: float = 15.0,
) -> FloatArray:
    """Low-pass a per-frame curvature with the RTK truth's filter along its arc length.

    Args:
        s_m: RTK arc length at each frame, metres (NaN without truth).
        value: Per-frame values (1/m), NaN where unknown.
        window_m: Savitzky-Golay window, metres (the RTK truth's).
        ds_m: Resampling step, metres.
        max_gap_m: Frames more than this apart along ``s`` are not bridged, metres.

    Returns:
        The smoothed values where they and the truth's arc length exist (NaN near the ends of
        each run, as for the truth); ``value`` unchanged when there is no arc length at all.
    """
    s = np.asarray(s_m, dtype=np.float64)
    v = np.asarray(value, dtype=np.float64)
    if not np.isfinite(s).any():
        return v.copy()
    return _smooth_blocks(s, v, ds_m, window_m, max_gap_m, 0)
