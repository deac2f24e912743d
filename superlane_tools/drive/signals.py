"""Small streams of a drive: CAN speed / yaw rate, Mobileye lanes, and the RTK curvature truth.

These streams are small (a few hundred bytes per second), so they are collected whole during the
streaming pass and processed afterwards; frames never are.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from superlane_tools.can import si_factor
from superlane_tools.drive.config import CanConfig, RtkConfig
from superlane_tools.geo import (
    curvature_noise_floor,
    geodetic_to_enu,
    grade_fixes,
    yaw_rate_curvature,
)
from superlane_tools.geo.curvature import (
    CurvatureParams,
    TrajectoryCurvature,
    trajectory_curvature,
)
from superlane_tools.geo.dynamics import DynamicsCurvature, DynamicsParams
from superlane_tools.recording.align import align
from superlane_tools.records import Message
from superlane_tools.reporting.gnss_fixes import GnssFixes

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
BoolArray = NDArray[np.bool_]

SIGNAL_TOLERANCE_NS = 200_000_000
"""CAN speed / yaw rate / Mobileye values apply to frames at most this far away in time."""


class Series(NamedTuple):
    """One signal over time: ``t_ns`` (int64 ns) and ``values`` (float64)."""

    t_ns: IntArray
    values: FloatArray


def signal_series(
    signals: pd.DataFrame, name: str, quantity: str = "", unit: str = ""
) -> Series | None:
    """Return the samples of the signal called ``name`` (any message), or None if absent.

    Args:
        signals: Decoded CAN signals.
        name: Signal name.
        quantity: ``speed`` or ``yaw_rate`` to convert the values to SI (m/s, rad/s) from the
            DBC's unit; "" keeps the values as decoded.
        unit: Unit overriding the DBC's (for DBCs without units).

    Raises:
        CanError: If the signal's unit is empty or unknown for ``quantity``.
    """
    rows = signals[signals["signal"] == name]
    if rows.empty:
        return None
    values = rows["value"].to_numpy(dtype=np.float64)
    if quantity:
        dbc_unit = str(rows["unit"].iloc[0]) if "unit" in rows.columns else ""
        values = values * si_factor(unit or dbc_unit, quantity, name)
    return Series(rows["log_time_ns"].to_numpy(dtype=np.int64), values)


def at_frames(series: Series | None, frame_t_ns: IntArray) -> FloatArray:
    """Sample a series at frame times (linear, no bridging of dropouts); NaN when absent."""
    if series is None:
        return np.full(frame_t_ns.shape, np.nan)
    return align(series.t_ns, series.values, frame_t_ns, "linear", SIGNAL_TOLERANCE_NS)


def can_frame_signals(signals: pd.DataFrame, config: CanConfig) -> tuple[Series | None, ...]:
    """Return the speed (m/s) and yaw-rate (rad/s) series named by the config (None if absent).

    Raises:
        CanError: If a used signal's unit is empty or unknown (see ``can.speed_unit``).
    """
    return signal_series(signals, config.speed_signal, "speed", config.speed_unit), signal_series(
        signals, config.yaw_rate_signal, "yaw_rate", config.yaw_rate_unit
    )


def mobileye_at_frames(
    table: pd.DataFrame, frame_t_ns: IntArray, column: str = "curvature"
) -> FloatArray:
    """Return a Mobileye column (default the curvature, 1/m, left positive) at frame times.

    NaN without data, and where the nearest update is invalid (NaN), never 0.0.
    """
    if table.empty or column not in table.columns:
        return np.full(frame_t_ns.shape, np.nan)
    return align(
        table["log_time_ns"].to_numpy(dtype=np.int64),
        table[column].to_numpy(dtype=np.float64),
        frame_t_ns,
        "nearest",
        SIGNAL_TOLERANCE_NS,
    )


class RtkTruth(NamedTuple):
    """The RTK ground truth.

    Attributes:
        fixes: One row per fix (``rtk.parquet`` columns; see ``docs/reprocess.md``).
        frame_s_m: Arc length at each frame, metres (NaN without truth).
        frame_heading_rad: Heading at each frame, radians from east, counter-clockwise.
        frame_curvature: Path curvature at each frame, 1/m, left positive (NaN without truth).
        frame_valid: True where the truth rests on good fixes and a full smoothing window.
        n_good: Fixes accepted as ground truth.
        n_degraded: Fixes rejected (not RTK fixed, covariance too large, invalid).
        n_dropouts: Gaps longer than ``max_gap_s`` between consecutive fixes.
        degraded: True when the truth rests on plain (non-RTK) GNSS fixes.
        noise_floor_per_m: Curvature noise the fix noise alone causes (from the fixes'
            covariance, speed and rate; 2 cm assumed for RTK fixes without covariance), 1/m;
            NaN when unknown.
        n_slow: Good fixes excluded because the vehicle stood or crawled.
    """

    fixes: pd.DataFrame
    frame_s_m: FloatArray
    frame_heading_rad: FloatArray
    frame_curvature: FloatArray
    frame_valid: NDArray[np.bool_]
    n_good: int
    n_degraded: int
    n_dropouts: int
    degraded: bool = False
    noise_floor_per_m: float = math.nan
    n_slow: int = 0


def _worst_variance(fixes: GnssFixes) -> FloatArray:
    """Worse of the east and north variances per fix, m^2 (NaN where unknown)."""
    east, north = fixes.covariance_m2[:, 0], fixes.covariance_m2[:, 4]
    with np.errstate(invalid="ignore"):
        known = fixes.has_covariance & ((east > 0) | (north > 0))
        worse = np.where(north > east, north, east)  # as max(east, north), NaN included
    return np.where(known, worse, np.nan)


def curvature_params(config: RtkConfig) -> CurvatureParams:
    """Return the arc-length curvature estimate's parameters of an ``[rtk]`` config section."""
    return CurvatureParams(
        ds_m=config.ds_m,
        window_m=config.window_m,
        polyorder=config.polyorder,
        max_gap_s=config.max_gap_s,
        min_run_m=config.min_run_m,
        min_speed_mps=config.min_speed_mps,
        min_step_m=config.min_step_m,
    )


def rtk_truth(
    gnss: GnssFixes,
    frame_t_ns: IntArray,
    config: RtkConfig,
    speed: Series | None = None,
) -> RtkTruth:
    """Turn collected fixes (``GnssCollector.fixes``) into the flagged trajectory and curvature.

    Fixes that are not RTK fixed (``status < min_status``), have a horizontal variance above
    ``max_horizontal_var_m2`` or an invalid position are flagged and excluded; a drive without
    any RTK fix uses its plain fixes and is flagged degraded (``truth degraded: not RTK``).
    Gaps longer than ``max_gap_s`` split the trajectory; fixes below ``min_speed_mps`` (CAN
    speed when given, else the fixes' own) give no truth (see
    :mod:`superlane_tools.geo.curvature`).
    """
    n_frames = frame_t_ns.shape[0]
    nan = np.full(n_frames, np.nan)
    if not len(gnss):
        empty = pd.DataFrame()
        return RtkTruth(empty, nan, nan.copy(), nan.copy(), np.zeros(n_frames, bool), 0, 0, 0)
    var = _worst_variance(gnss)
    grades = grade_fixes(
        gnss.latitude_deg,
        gnss.longitude_deg,
        gnss.altitude_m,
        gnss.fix_status_or_nan(),
        var,
        config.min_status,
        config.max_horizontal_var_m2,
    )
    good = grades.good
    t = gnss.log_time_ns
    east, north, up = _good_enu(gnss, good)
    gap_s = np.concatenate([[0.0], np.diff(t) / 1e9])
    dropout = gap_s > config.max_gap_s
    params = curvature_params(config)
    fix_speed_mps = _fix_speed_mps(speed, t, good, east, north)
    at_fix = trajectory_curvature(t, east, north, good, t, params, fix_speed_mps)
    at_frame = trajectory_curvature(t, east, north, good, frame_t_ns, params, fix_speed_mps)
    with np.errstate(invalid="ignore"):
        slow = good & ~(fix_speed_mps >= config.min_speed_mps)
    valid = at_frame.valid & _near_a_good_fix(t[good], frame_t_ns, config.max_frame_gap_s)
    curvature = np.where(valid, at_frame.curvature_per_m, np.nan)
    fixes = _fixes_table(gnss, (east, north, up), grades.reasons, good, gap_s, dropout, at_fix)
    fixes["speed_mps"] = fix_speed_mps
    fixes["slow"] = slow
    return RtkTruth(
        fixes,
        at_frame.s_m,
        at_frame.heading_rad,
        curvature,
        valid,
        int(good.sum()),
        int((~good).sum()),
        int(dropout.sum()),
        grades.degraded,
        _noise_floor(t, var, good & ~slow, fix_speed_mps, grades.degraded, config),
        int(slow.sum()),
    )


def _good_enu(gnss: GnssFixes, good: BoolArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """East, north, up (m) of the good fixes, around the first of them; NaN elsewhere."""
    east = np.full(len(gnss), np.nan)
    north, up = east.copy(), east.copy()
    if good.any():
        lat = np.where(good, gnss.latitude_deg, np.nan)
        enu = geodetic_to_enu(lat, gnss.longitude_deg, gnss.altitude_m)
        east, north, up = enu.east_m, enu.north_m, enu.up_m
    return east, north, up


def _fix_speed_mps(
    speed: Series | None, t: IntArray, good: BoolArray, east: FloatArray, north: FloatArray
) -> FloatArray:
    """Speed (m/s) at each fix: CAN speed when it has values there, else the fixes' own."""
    fix_speed_mps = None
    if speed is not None:
        fix_speed_mps = align(speed.t_ns, speed.values, t, "linear", SIGNAL_TOLERANCE_NS)
    if fix_speed_mps is None or not np.isfinite(fix_speed_mps).any():
        from superlane_tools.geo import fix_speed

        fix_speed_mps = fix_speed(t, np.where(good, east, np.nan), np.where(good, north, np.nan))
    return fix_speed_mps


def _near_a_good_fix(good_t: IntArray, frame_t_ns: IntArray, max_gap_s: float) -> BoolArray:
    """Frames at most ``max_gap_s`` from a good fix (all frames when there is none)."""
    near_ok = np.ones(frame_t_ns.shape[0], dtype=bool)
    if good_t.size:
        near = np.searchsorted(good_t, frame_t_ns)
        d_prev = np.abs(frame_t_ns - good_t[np.clip(near - 1, 0, good_t.size - 1)])
        d_next = np.abs(good_t[np.clip(near, 0, good_t.size - 1)] - frame_t_ns)
        near_ok = np.minimum(d_prev, d_next) <= max_gap_s * 1e9
    return near_ok


def _fixes_table(
    gnss: GnssFixes,
    enu: tuple[FloatArray, FloatArray, FloatArray],
    reasons: list[str],
    good: BoolArray,
    gap_s: FloatArray,
    dropout: BoolArray,
    at_fix: TrajectoryCurvature,
) -> pd.DataFrame:
    """One row per fix: position, grade, gaps and the trajectory's curvature there."""
    east, north, up = enu
    return pd.DataFrame(
        {
            "log_time_ns": gnss.log_time_ns,
            "topic": gnss.topic_names().astype(str),
            "latitude_deg": gnss.latitude_deg,
            "longitude_deg": gnss.longitude_deg,
            "altitude_m": gnss.altitude_m,
            "fix_status": pd.arrays.IntegerArray(
                gnss.fix_status.astype(np.int8), ~gnss.has_fix_status
            ),
            "east_m": east,
            "north_m": north,
            "up_m": up,
            "good": good,
            "flag": reasons,
            "gap_before_s": gap_s,
            "dropout_before": dropout,
            "s_m": at_fix.s_m,
            "heading_rad": at_fix.heading_rad,
            "curvature_per_m": np.where(at_fix.valid, at_fix.curvature_per_m, np.nan),
            "curvature_valid": at_fix.valid,
        }
    )


def _noise_floor(
    t: IntArray,
    var: FloatArray,
    used: NDArray[np.bool_],
    speed: FloatArray,
    degraded: bool,
    config: RtkConfig,
) -> float:
    """Curvature noise floor of the truth from its fixes' covariance, speed and rate, 1/m."""
    if used.sum() < 3:
        return math.nan
    known = var[used][np.isfinite(var[used])]
    if known.size:
        sigma = float(np.sqrt(np.median(known)))
    elif degraded:
        return math.nan  # plain GNSS without covariance: its noise is not known
    else:
        sigma = RTK_ASSUMED_SIGMA_M
    steps = np.diff(t[used])
    steps = steps[steps > 0]  # fixes may share a time stamp
    if not steps.size:
        return math.nan
    rate = 1e9 / float(np.median(steps))
    v = float(np.nanmedian(speed[used]))
    return curvature_noise_floor(
        sigma, v, rate, config.window_m, config.polyorder, config.min_step_m
    )


RTK_ASSUMED_SIGMA_M = 0.02
"""Horizontal noise of an RTK fixed fix without a covariance, metres (one axis)."""


class ImuSamples:
    """Collects ``sensor_msgs/Imu`` angular velocities (rad/s, IMU frame) during the pass."""

    def __init__(self) -> None:
        self.times: list[int] = []
        self.gyro: list[tuple[float, float, float]] = []

    def add(self, msg: Message) -> None:
        """Keep one Imu message's time and angular velocity."""
        w = msg.data.angular_velocity
        self.times.append(msg.log_time_ns)
        self.gyro.append((float(w.x), float(w.y), float(w.z)))

    def __len__(self) -> int:
        return len(self.times)

    def yaw_series(self, axis: str) -> Series | None:
        """Return the yaw rate (rad/s, left positive) about ``axis`` (``z``, ``-z``, ``x``, ...).

        Raises:
            ConfigError: If the axis is not one of x, y, z with an optional minus sign.
        """
        from superlane_tools.errors import ConfigError

        name = axis.strip().lower()
        sign = -1.0 if name.startswith("-") else 1.0
        index = {"x": 0, "y": 1, "z": 2}.get(name.lstrip("+-"))
        if index is None:
            raise ConfigError(
                f"dynamics.imu_yaw_axis must be x, y or z (optionally -), not {axis!r}"
            )
        if not self.times:
            return None
        values = sign * np.asarray(self.gyro, dtype=np.float64)[:, index]
        order = np.argsort(np.asarray(self.times, dtype=np.int64), kind="stable")
        return Series(np.asarray(self.times, dtype=np.int64)[order], values[order])


def dynamics_reference(
    yaw: Series | None, speed: Series | None, frame_t_ns: IntArray, config: RtkConfig
) -> DynamicsCurvature | None:
    """Return the yaw-rate / speed path curvature at frame times, smoothed like the RTK truth.

    None when the yaw rate or the speed is missing.
    """
    if yaw is None or speed is None or len(yaw.t_ns) < 3:
        return None
    params = DynamicsParams(curvature=curvature_params(config))
    return yaw_rate_curvature(yaw.t_ns, yaw.values, speed.t_ns, speed.values, frame_t_ns, params)


def gnss_speed(truth: RtkTruth) -> Series | None:
    """Return the speed estimated from the good fixes (m/s), the fallback for CAN speed."""
    fixes = truth.fixes
    if fixes.empty or "speed_mps" not in fixes.columns:
        return None
    rows = fixes[fixes["good"] & np.isfinite(fixes["speed_mps"])]
    if rows.empty:
        return None
    return Series(
        rows["log_time_ns"].to_numpy(dtype=np.int64), rows["speed_mps"].to_numpy(dtype=np.float64)
    )
