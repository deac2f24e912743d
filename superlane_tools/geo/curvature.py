"""Road curvature ground truth from an RTK trajectory: arc-length resampling and smoothing.

Method (documented in ``docs/extract.md`` and the reprocess report):

1. Fixes flagged as degraded (float / standalone / no fix), fixes taken while the vehicle stands
   or crawls (speed below ``min_speed_mps``, from CAN or from the fixes themselves) and fixes
   isolated by a dropout longer than ``max_gap_s`` split the trajectory into valid runs; nothing
   is interpolated across them. At standstill the fix jitter (centimetres) would otherwise add
   phantom arc length and its second derivative would reach 1e-3..1e4 1/m.
2. Within a run, fixes are decimated to a minimum step ``min_step_m`` (well above the fixes'
   noise) from the last kept fix, so that arc length is not built from noise; the kept
   positions are parameterised by cumulative arc length ``s`` and resampled every ``ds_m``
   metres by linear interpolation.
3. A Savitzky-Golay filter (``scipy.signal.savgol_filter``, polynomial order ``polyorder``,
   window ``window_m`` metres) smooths east/north and gives their first and second derivatives
   with respect to ``s`` directly.
4. Heading ``psi = atan2(dN/ds, dE/ds)`` (radians, counter-clockwise from east) and signed
   curvature ``kappa = (E' N'' - N' E'') / (E'^2 + N'^2)^1.5`` (1/m). Positive curvature turns
   **left** (counter-clockwise), the same sign as the lane model's ``2*a2`` with y left.
5. Values are mapped to query times through ``s(t)`` of the fixes; times outside a valid run
   (or within half a window of its ends, where the filter is one-sided) are NaN / flagged.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray
from scipy.signal import savgol_filter

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]


@dataclass(frozen=True)
class CurvatureParams:
    """Parameters of the RTK curvature estimate.

    Attributes:
        ds_m: Arc-length resampling step, metres.
        window_m: Savitzky-Golay window length, metres.
        polyorder: Savitzky-Golay polynomial order (>= 2 for curvature).
        max_gap_s: A time gap between fixes longer than this splits the trajectory (dropout), s.
        min_run_m: Valid runs shorter than this are discarded, metres.
        min_speed_mps: No truth below this speed (standing, crawling), metres per second.
        min_step_m: Fixes closer than this to the last kept fix are dropped before arc length
            is built, metres (about ten times a 2 cm RTK fix noise).
    """

    ds_m: float = 0.5
    window_m: float = 30.0
    polyorder: int = 3
    max_gap_s: float = 0.5
    min_run_m: float = 10.0
    min_speed_mps: float = 2.0
    min_step_m: float = 0.25


class TrajectoryCurvature(NamedTuple):
    """Heading and curvature of a trajectory at query times.

    Attributes:
        s_m: Arc length along the trajectory at each query time, metres (NaN if unknown).
        heading_rad: Heading, radians, counter-clockwise from east (ENU).
        curvature_per_m: Signed curvature, 1/m, left (counter-clockwise) positive.
        valid: True where the estimate rests on good fixes with a full smoothing window.
    """

    s_m: FloatArray
    heading_rad: FloatArray
    curvature_per_m: FloatArray
    valid: BoolArray


def _runs(t_ns: NDArray[np.int64], good: BoolArray, max_gap_ns: int) -> list[NDArray[np.intp]]:
    """Split fix indices into runs of good fixes without dropouts."""
    idx = np.flatnonzero(good)
    if idx.size == 0:
        return []
    breaks = np.flatnonzero((np.diff(t_ns[idx]) > max_gap_ns) | (np.diff(idx) > 1)) + 1
    return [r for r in np.split(idx, breaks) if r.size >= 3]


def _decimate(east_m: FloatArray, north_m: FloatArray, min_step_m: float) -> BoolArray:
    """Keep a fix only when it lies at least ``min_step_m`` from the last kept fix."""
    keep = np.zeros(east_m.shape, dtype=bool)
    if east_m.size == 0:
        return keep
    keep[0] = True
    last_e, last_n = east_m[0], north_m[0]
    for i in range(1, east_m.size):
        if math.hypot(east_m[i] - last_e, north_m[i] - last_n) >= min_step_m:
            keep[i] = True
            last_e, last_n = east_m[i], north_m[i]
    return keep


def fix_speed(
    t_ns: NDArray[np.int64], east_m: FloatArray, north_m: FloatArray, baseline_s: float = 1.0
) -> FloatArray:
    """Estimate the speed at each fix from the fixes themselves, metres per second.

    The displacement over about ``baseline_s`` (centred) is used rather than neighbouring
    fixes: with 2 cm noise at 10 Hz, neighbour differences alone read 0.3 m/s at standstill.

    Args:
        t_ns: Fix times, integer nanoseconds, increasing.
        east_m: East coordinates, metres (NaN where invalid).
        north_m: North coordinates, metres.
        baseline_s: Time span the displacement is measured over, seconds.

    Returns:
        Speed per fix, m/s (NaN where no neighbour within the baseline is valid).
    """
    t = np.asarray(t_ns, dtype=np.int64)
    e = np.asarray(east_m, dtype=np.float64)
    n = np.asarray(north_m, dtype=np.float64)
    out = np.full(t.shape, np.nan)
    ok = np.flatnonzero(np.isfinite(e) & np.isfinite(n))
    if ok.size < 2:
        return out
    tk = t[ok]
    half = int(0.5 * baseline_s * 1e9)
    lo = np.searchsorted(tk, tk - half, "left")
    hi = np.clip(np.searchsorted(tk, tk + half, "right") - 1, 0, ok.size - 1)
    span = (tk[hi] - tk[lo]).astype(np.float64) * 1e-9
    dist = np.hypot(e[ok][hi] - e[ok][lo], n[ok][hi] - n[ok][lo])
    with np.errstate(invalid="ignore", divide="ignore"):
        out[ok] = np.where(span > 0, dist / span, np.nan)
    return out


def trajectory_curvature(
    t_ns: NDArray[np.int64],
    east_m: FloatArray,
    north_m: FloatArray,
    good: BoolArray,
    query_t_ns: NDArray[np.int64],
    params: CurvatureParams | None = None,
    speed_mps: FloatArray | None = None,
) -> TrajectoryCurvature:
    """Estimate heading and curvature of an ENU trajectory at query times.

    Args:
        t_ns: Fix times, integer nanoseconds, increasing.
        east_m: East coordinates of the fixes, metres.
        north_m: North coordinates of the fixes, metres.
        good: True for fixes usable as ground truth (RTK fixed); others are excluded.
        query_t_ns: Times to evaluate at (e.g. camera frame times), nanoseconds.
        params: Smoothing parameters (defaults: 0.5 m step, 30 m window, order 3).
        speed_mps: Vehicle speed at each fix (e.g. CAN speed), m/s; None: estimated from the
            fixes (:func:`fix_speed`). Fixes slower than ``params.min_speed_mps`` are excluded.

    Returns:
        Arc length, heading, curvature and validity at each query time.
    """
    p = params or CurvatureParams()
    t = np.asarray(t_ns, dtype=np.int64)
    e = np.asarray(east_m, dtype=np.float64)
    n = np.asarray(north_m, dtype=np.float64)
    q = np.asarray(query_t_ns, dtype=np.int64)
    ok = np.asarray(good, dtype=bool) & np.isfinite(e) & np.isfinite(n)
    if p.min_speed_mps > 0:
        speed = (
            fix_speed(t, np.where(ok, e, np.nan), np.where(ok, n, np.nan))
            if speed_mps is None
            else np.asarray(speed_mps, dtype=np.float64)
        )
        with np.errstate(invalid="ignore"):
            ok &= speed >= p.min_speed_mps
    out_s = np.full(q.shape, np.nan)
    out_h = np.full(q.shape, np.nan)
    out_k = np.full(q.shape, np.nan)
    out_v = np.zeros(q.shape, dtype=bool)
    window = max(round(p.window_m / p.ds_m) | 1, (p.polyorder + 2) | 1)
    s_offset = 0.0
    for candidate in _runs(t, ok, int(p.max_gap_s * 1e9)):
        run = candidate[_decimate(e[candidate], n[candidate], max(p.min_step_m, 1e-3))]
        if run.size < 3:
            continue
        s_fix = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(e[run]), np.diff(n[run])))])
        length = float(s_fix[-1])
        if length < max(p.min_run_m, window * p.ds_m):
            continue
        s_grid = np.arange(0.0, length, p.ds_m)
        eg = np.interp(s_grid, s_fix, e[run])
        ng = np.interp(s_grid, s_fix, n[run])
        d1e = savgol_filter(eg, window, p.polyorder, deriv=1, delta=p.ds_m, mode="interp")
        d1n = savgol_filter(ng, window, p.polyorder, deriv=1, delta=p.ds_m, mode="interp")
        d2e = savgol_filter(eg, window, p.polyorder, deriv=2, delta=p.ds_m, mode="interp")
        d2n = savgol_filter(ng, window, p.polyorder, deriv=2, delta=p.ds_m, mode="interp")
        heading = np.unwrap(np.arctan2(d1n, d1e))
        kappa = (d1e * d2n - d1n * d2e) / np.power(d1e * d1e + d1n * d1n, 1.5)
        t_run = t[run].astype(np.float64)
        inside = (q >= t[run[0]]) & (q <= t[run[-1]])
        if not inside.any():
            s_offset += length
            continue
        s_q = np.interp(q[inside].astype(np.float64), t_run, s_fix)
        out_s[inside] = s_q + s_offset
        out_h[inside] = np.interp(s_q, s_grid, heading)
        out_k[inside] = np.interp(s_q, s_grid, kappa)
        half = 0.5 * window * p.ds_m
        out_v[inside] = (s_q >= half) & (s_q <= length - half)
        s_offset += length
    out_h = np.arctan2(np.sin(out_h), np.cos(out_h))
    return TrajectoryCurvature(out_s, out_h, out_k, out_v)
