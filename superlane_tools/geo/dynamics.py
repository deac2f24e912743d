"""Path curvature from vehicle dynamics: yaw rate over speed, smoothed like the RTK truth.

An independent reference for the vehicle's path curvature: ``kappa = (r - b) / v`` with the yaw
rate ``r`` (CAN yaw-rate signal or an IMU's gyro about the vertical axis, rad/s, left
positive), its bias ``b`` and the speed ``v`` (m/s). To give it exactly the low-pass of the RTK
truth, heading and position are dead-reckoned from ``r - b`` and ``v`` and passed through the
same arc-length Savitzky-Golay estimate (:func:`superlane_tools.geo.curvature.
trajectory_curvature`); curvature is invariant to the dead-reckoning drift in heading and
position. Below ``min_speed_mps`` there is no reference (``kappa`` diverges as ``v -> 0``).

Gyro bias: the median yaw rate while standing (speed below ``standstill_mps`` for at least
``min_standstill_s``) when the drive has such samples; else a bias given by the caller (e.g.
the IMU driver's own estimate); else zero, and the result says so.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from superlane_tools.geo.curvature import CurvatureParams, trajectory_curvature

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
BoolArray = NDArray[np.bool_]


@dataclass(frozen=True)
class DynamicsParams:
    """Parameters of the yaw-rate curvature reference.

    Attributes:
        curvature: Smoothing and gating shared with the RTK truth (window, speed gate, gaps).
        standstill_mps: Speed below which the vehicle stands (gyro bias samples), m/s.
        min_standstill_s: Standstill time needed to estimate the bias, seconds.
        speed_tolerance_s: Speed samples apply at most this far from a yaw-rate sample, s.
    """

    curvature: CurvatureParams = field(default_factory=CurvatureParams)
    standstill_mps: float = 0.05
    min_standstill_s: float = 1.0
    speed_tolerance_s: float = 0.2


class GyroBias(NamedTuple):
    """A yaw-rate bias and where it came from.

    Attributes:
        rps: The bias, rad/s (subtracted from the yaw rate).
        source: ``standstill`` (median while standing), ``given`` or ``none`` (zero).
        samples: Yaw-rate samples the standstill estimate rests on.
    """

    rps: float
    source: str
    samples: int


class DynamicsCurvature(NamedTuple):
    """The dynamics path-curvature reference at query times.

    Attributes:
        curvature_per_m: Path curvature, 1/m, left positive (NaN where not valid).
        valid: True where speed, yaw rate and a full smoothing window exist.
        s_m: Dead-reckoned arc length at each query time, metres.
        bias: The gyro bias used.
    """

    curvature_per_m: FloatArray
    valid: BoolArray
    s_m: FloatArray
    bias: GyroBias


def gyro_bias(
    t_ns: IntArray,
    yaw_rate_rps: FloatArray,
    speed_mps: FloatArray,
    params: DynamicsParams,
    given_rps: float | None = None,
) -> GyroBias:
    """Estimate the yaw-rate bias from standstill samples (see the module docstring).

    Args:
        t_ns: Yaw-rate sample times, integer nanoseconds.
        yaw_rate_rps: Yaw rate, rad/s.
        speed_mps: Speed at the same times, m/s (NaN unknown).
        params: Thresholds.
        given_rps: Bias to use when the drive never stands; None: zero.

    Returns:
        The bias, its source and sample count.
    """
    yaw = np.asarray(yaw_rate_rps, dtype=np.float64)
    with np.errstate(invalid="ignore"):
        still = np.isfinite(yaw) & (np.asarray(speed_mps) < params.standstill_mps)
    if still.sum() >= 2:
        t = np.asarray(t_ns, dtype=np.int64)[still]
        dt = np.diff(t) * 1e-9
        duration = float(dt[dt < 0.5].sum())
        if duration >= params.min_standstill_s:
            return GyroBias(float(np.median(yaw[still])), "standstill", int(still.sum()))
    if given_rps is not None and np.isfinite(given_rps):
        return GyroBias(float(given_rps), "given", 0)
    return GyroBias(0.0, "none", 0)


def yaw_rate_curvature(
    yaw_t_ns: IntArray,
    yaw_rate_rps: FloatArray,
    speed_t_ns: IntArray,
    speed_mps: FloatArray,
    query_t_ns: IntArray,
    params: DynamicsParams | None = None,
    given_bias_rps: float | None = None,
) -> DynamicsCurvature:
    """Return the path curvature from yaw rate and speed at query times, smoothed on arc length.

    Args:
        yaw_t_ns: Yaw-rate sample times, integer nanoseconds, increasing.
        yaw_rate_rps: Yaw rate, rad/s, counter-clockwise (left) positive.
        speed_t_ns: Speed sample times, integer nanoseconds, increasing.
        speed_mps: Speed over ground, m/s.
        query_t_ns: Times to evaluate at (camera frames, fixes), nanoseconds.
        params: Smoothing, gating and bias parameters.
        given_bias_rps: Bias to use when the drive never stands still, rad/s.

    Returns:
        Curvature (1/m), validity, arc length (m) and the bias used.
    """
    p = params or DynamicsParams()
    t = np.asarray(yaw_t_ns, dtype=np.int64)
    yaw = np.asarray(yaw_rate_rps, dtype=np.float64)
    q = np.asarray(query_t_ns, dtype=np.int64)
    v = _speed_at(np.asarray(speed_t_ns, np.int64), np.asarray(speed_mps, np.float64), t, p)
    bias = gyro_bias(t, yaw, v, p, given_bias_rps)
    nan = np.full(q.shape, np.nan)
    if t.size < 3:
        return DynamicsCurvature(nan, np.zeros(q.shape, bool), nan.copy(), bias)
    ok = np.isfinite(yaw) & np.isfinite(v)
    dt = np.concatenate([[0.0], np.diff(t) * 1e-9])
    dt[1:][np.diff(t) * 1e-9 > p.curvature.max_gap_s] = 0.0
    rate = np.where(ok, yaw - bias.rps, 0.0)
    heading = np.cumsum(rate * dt)
    speed = np.where(ok, v, 0.0)
    east = np.cumsum(speed * np.cos(heading) * dt)
    north = np.cumsum(speed * np.sin(heading) * dt)
    # Dead-reckoned positions carry no fix noise: decimate only against rounding.
    cp = replace(p.curvature, min_step_m=min(p.curvature.min_step_m, 0.05))
    res = trajectory_curvature(t, east, north, ok, q, cp, speed_mps=np.where(ok, v, np.nan))
    curvature = np.where(res.valid, res.curvature_per_m, np.nan)
    return DynamicsCurvature(curvature, res.valid, res.s_m, bias)


def _speed_at(
    speed_t_ns: IntArray, speed_mps: FloatArray, t_ns: IntArray, p: DynamicsParams
) -> FloatArray:
    """Interpolate the speed at ``t_ns``; NaN farther than the tolerance from any sample."""
    out = np.full(t_ns.shape, np.nan)
    ok = np.isfinite(speed_mps)
    st, sv = speed_t_ns[ok], speed_mps[ok]
    if st.size == 0:
        return out
    out = np.interp(t_ns.astype(np.float64), st.astype(np.float64), sv)
    idx = np.clip(np.searchsorted(st, t_ns), 1, max(st.size - 1, 1))
    near = np.minimum(np.abs(t_ns - st[idx - 1]), np.abs(st[np.minimum(idx, st.size - 1)] - t_ns))
    out[near > p.speed_tolerance_s * 1e9] = np.nan
    return out
