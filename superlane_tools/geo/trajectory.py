"""Speed and heading from an ENU trajectory, robust to duplicate timestamps and dropouts."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from superlane_tools.geo.errors import GeoError

MAX_GAP_NS = 2_000_000_000
"""Neighbours further apart than this (a dropout) are not differenced, nanoseconds."""

MIN_HEADING_SPEED_MPS = 0.2
"""Below this speed the heading is undefined (NaN): GNSS noise dominates the direction."""


class Kinematics(NamedTuple):
    """Speed and heading per trajectory sample.

    Attributes:
        speed_mps: (N,) horizontal speed, metres per second (NaN where undefined).
        heading_rad: (N,) course over ground in the ENU frame, radians counter-clockwise from
            east in (-pi, pi] (NaN where undefined or slower than the heading threshold).
    """

    speed_mps: npt.NDArray[np.float64]
    heading_rad: npt.NDArray[np.float64]


def speed_heading(
    t_ns: npt.ArrayLike,
    east_m: npt.ArrayLike,
    north_m: npt.ArrayLike,
    max_gap_ns: int = MAX_GAP_NS,
    min_heading_speed_mps: float = MIN_HEADING_SPEED_MPS,
) -> Kinematics:
    """Estimate speed and heading by central differences over distinct, valid samples.

    Samples sharing a timestamp are averaged into one point first (duplicates would divide by
    zero); NaN positions are dropped. Each point uses the neighbours on both sides when both
    are within ``max_gap_ns``, else the one that is, else nothing (NaN). Results are mapped
    back to every input sample (duplicates get their group's value).

    Args:
        t_ns: (N,) sample times, integer nanoseconds (any order).
        east_m: (N,) east positions, metres.
        north_m: (N,) north positions, metres.
        max_gap_ns: Largest time step that is differenced, nanoseconds.
        min_heading_speed_mps: Speed below which the heading is NaN, metres per second.

    Returns:
        Speed (m/s) and heading (rad, ENU, counter-clockwise from east) per input sample.

    Raises:
        GeoError: If the arrays differ in length.
    """
    t = np.asarray(t_ns, dtype=np.int64)
    east = np.asarray(east_m, dtype=np.float64)
    north = np.asarray(north_m, dtype=np.float64)
    if not t.shape == east.shape == north.shape or t.ndim != 1:
        raise GeoError(f"trajectory arrays differ in shape: {t.shape}, {east.shape}")
    speed = np.full(t.shape, np.nan)
    heading = np.full(t.shape, np.nan)
    ok = np.isfinite(east) & np.isfinite(north)
    if ok.sum() < 2:
        return Kinematics(speed, heading)
    times, group = np.unique(t[ok], return_inverse=True)
    counts = np.bincount(group).astype(np.float64)
    e = np.bincount(group, weights=east[ok]) / counts
    n = np.bincount(group, weights=north[ok]) / counts
    m = len(times)
    if m < 2:
        return Kinematics(speed, heading)
    dt = np.diff(times)
    usable = dt <= max_gap_ns
    lo = np.arange(m)
    hi = np.arange(m)
    back = np.concatenate([[False], usable])  # step i-1 -> i usable
    fwd = np.concatenate([usable, [False]])  # step i -> i+1 usable
    lo[back] -= 1
    hi[fwd] += 1
    has = hi > lo
    span_s = (times[hi] - times[lo]).astype(np.float64) * 1e-9
    de = e[hi] - e[lo]
    dn = n[hi] - n[lo]
    with np.errstate(invalid="ignore", divide="ignore"):
        v = np.where(has, np.hypot(de, dn) / span_s, np.nan)
    h = np.where(has & (v >= min_heading_speed_mps), np.arctan2(dn, de), np.nan)
    speed[ok] = v[group]
    heading[ok] = h[group]
    return Kinematics(speed, heading)
