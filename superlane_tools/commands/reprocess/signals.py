"""Small streams of a drive: CAN speed / yaw rate, Mobileye lanes, and the RTK curvature truth.

These streams are small (a few hundred bytes per second), so they are collected whole during the
streaming pass and processed afterwards; frames never are.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any, NamedTuple

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from superlane_tools.commands.reprocess.config import CanConfig, RtkConfig
from superlane_tools.geo import geodetic_to_enu, valid_fixes
from superlane_tools.geo.curvature import CurvatureParams, trajectory_curvature
from superlane_tools.recording.align import align

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

MOBILEYE_SIDES = {"left": ("Left_Lane_A", "Left_Lane_B"), "right": ("Right_Lane_A", "Right_Lane_B")}
"""Mobileye lane messages per side (part A: C0, C2, C3, quality; part B: C1, view range)."""
MOBILEYE_PAIR_TOLERANCE_NS = 20_000_000
"""Part B of a Mobileye lane message is paired with the part A at most this far away."""
SIGNAL_TOLERANCE_NS = 200_000_000
"""CAN speed / yaw rate / Mobileye values apply to frames at most this far away in time."""


class Series(NamedTuple):
    """One signal over time: ``t_ns`` (int64 ns) and ``values`` (float64)."""

    t_ns: IntArray
    values: FloatArray


def signal_series(signals: pd.DataFrame, name: str) -> Series | None:
    """Return the samples of the signal called ``name`` (any message), or None if absent."""
    rows = signals[signals["signal"] == name]
    if rows.empty:
        return None
    return Series(
        rows["log_time_ns"].to_numpy(dtype=np.int64), rows["value"].to_numpy(dtype=np.float64)
    )


def at_frames(series: Series | None, frame_t_ns: IntArray) -> FloatArray:
    """Sample a series at frame times (linear, no bridging of dropouts); NaN when absent."""
    if series is None:
        return np.full(frame_t_ns.shape, np.nan)
    return align(series.t_ns, series.values, frame_t_ns, "linear", SIGNAL_TOLERANCE_NS)


def can_frame_signals(signals: pd.DataFrame, config: CanConfig) -> tuple[Series | None, ...]:
    """Return the speed and yaw-rate series named by the config (None where absent)."""
    return signal_series(signals, config.speed_signal), signal_series(
        signals, config.yaw_rate_signal
    )


def _message_wide(signals: pd.DataFrame, message: str) -> pd.DataFrame:
    rows = signals[signals["message"] == message]
    if rows.empty:
        return pd.DataFrame({"log_time_ns": pd.Series(dtype=np.int64)})
    wide = rows.pivot_table(
        index="log_time_ns", columns="signal", values="value", aggfunc="last", observed=True
    )
    wide.columns = [str(c) for c in wide.columns]
    return wide.reset_index().sort_values("log_time_ns", ignore_index=True)


def mobileye_table(signals: pd.DataFrame, right_positive: bool = True) -> pd.DataFrame:
    """Build one row per Mobileye lane update: both ego lines in the lane model's convention.

    Coefficients are converted to ``y = a0 + a1 x + a2 x^2 + a3 x^3`` with ``y`` left positive
    (EyeQ's ``C0..C3`` are right positive: ``a_k = -C_k``). Curvature per side is ``2 * a2``
    (1/m, left positive); ``curvature`` is the mean of the high-quality sides (quality >= 2), or
    of all sides when none is high quality.

    Returns:
        Columns ``log_time_ns`` and, per side ``left``/``right``: ``{side}_a0_m``,
        ``{side}_a1_rad``, ``{side}_a2_per_m``, ``{side}_a3_per_m2``, ``{side}_quality``,
        ``{side}_view_range_m``, ``{side}_curvature``; then ``curvature``. Empty when the
        recording has no Mobileye lane messages.
    """
    sign = -1.0 if right_positive else 1.0
    sides: dict[str, pd.DataFrame] = {}
    for side, (msg_a, msg_b) in MOBILEYE_SIDES.items():
        part_a = _message_wide(signals, msg_a)
        if part_a.empty:
            continue
        part_b = _message_wide(signals, msg_b)
        t_a = part_a["log_time_ns"].to_numpy(dtype=np.int64)
        frame = pd.DataFrame({"log_time_ns": t_a})

        def col(df: pd.DataFrame, name: str, times: IntArray) -> FloatArray:
            if name not in df.columns or df.empty:
                return np.full(times.shape, np.nan)
            return align(
                df["log_time_ns"].to_numpy(dtype=np.int64),
                df[name].to_numpy(dtype=np.float64),
                times,
                "nearest",
                MOBILEYE_PAIR_TOLERANCE_NS,
            )

        frame[f"{side}_a0_m"] = sign * col(part_a, "Curve_Parameter_C0", t_a)
        frame[f"{side}_a1_rad"] = sign * col(part_b, "Curve_Parameter_C1", t_a)
        frame[f"{side}_a2_per_m"] = sign * col(part_a, "Curve_Parameter_C2", t_a)
        frame[f"{side}_a3_per_m2"] = sign * col(part_a, "Curve_Parameter_C3", t_a)
        frame[f"{side}_quality"] = col(part_a, "Quality", t_a)
        view = col(part_b, "View_Range", t_a)
        avail = col(part_b, "View_Range_Available", t_a)
        frame[f"{side}_view_range_m"] = np.where(avail == 0, np.nan, view)
        frame[f"{side}_curvature"] = 2.0 * frame[f"{side}_a2_per_m"]
        sides[side] = frame
    if not sides:
        return pd.DataFrame({"log_time_ns": pd.Series(dtype=np.int64)})
    merged: pd.DataFrame | None = None
    for frame in sides.values():
        merged = (
            frame
            if merged is None
            else pd.merge_asof(
                merged.sort_values("log_time_ns"),
                frame.sort_values("log_time_ns"),
                on="log_time_ns",
                direction="nearest",
                tolerance=MOBILEYE_PAIR_TOLERANCE_NS,
            )
        )
    assert merged is not None
    curv = np.stack([merged[f"{s}_curvature"].to_numpy(dtype=np.float64) for s in sides], axis=1)
    qual = np.stack([merged[f"{s}_quality"].to_numpy(dtype=np.float64) for s in sides], axis=1)
    good = np.isfinite(curv) & (qual >= 2)
    use = np.where(good.any(axis=1, keepdims=True), good, np.isfinite(curv))
    with np.errstate(invalid="ignore"):
        mean = np.where(use, curv, 0.0).sum(axis=1) / use.sum(axis=1)
    merged["curvature"] = np.where(use.any(axis=1), mean, np.nan)
    return merged.reset_index(drop=True)


def mobileye_at_frames(table: pd.DataFrame, frame_t_ns: IntArray) -> FloatArray:
    """Return the Mobileye curvature (1/m, left positive) at frame times; NaN without data."""
    if table.empty or "curvature" not in table.columns:
        return np.full(frame_t_ns.shape, np.nan)
    return align(
        table["log_time_ns"].to_numpy(dtype=np.int64),
        table["curvature"].to_numpy(dtype=np.float64),
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
    """

    fixes: pd.DataFrame
    frame_s_m: FloatArray
    frame_heading_rad: FloatArray
    frame_curvature: FloatArray
    frame_valid: NDArray[np.bool_]
    n_good: int
    n_degraded: int
    n_dropouts: int


def _fix_quality(frame: pd.DataFrame, config: RtkConfig) -> tuple[NDArray[np.bool_], list[str]]:
    lat = frame["latitude_deg"].to_numpy(dtype=np.float64)
    lon = frame["longitude_deg"].to_numpy(dtype=np.float64)
    alt = frame["altitude_m"].to_numpy(dtype=np.float64)
    usable = valid_fixes(lat, lon, alt)
    status = frame["fix_status"].to_numpy(dtype=np.float64, na_value=math.nan)
    var = np.full(len(frame), np.nan)
    var_n = var.copy()
    for i, cov in enumerate(frame["covariance_m2"]):
        if cov is not None and len(cov) == 9:
            var[i], var_n[i] = float(cov[0]), float(cov[4])
    worst = np.fmax(var, var_n)
    reasons: list[str] = []
    good = np.zeros(len(frame), dtype=bool)
    for i in range(len(frame)):
        if not usable[i]:
            reasons.append("invalid position")
        elif np.isfinite(status[i]) and status[i] < config.min_status:
            reasons.append(f"not RTK fixed (status {int(status[i])})")
        elif np.isfinite(worst[i]) and worst[i] > config.max_horizontal_var_m2:
            reasons.append(f"covariance {worst[i]:.3g} m^2")
        else:
            reasons.append("")
            good[i] = True
    return good, reasons


def rtk_truth(
    rows: Sequence[Mapping[str, Any]], frame_t_ns: IntArray, config: RtkConfig
) -> RtkTruth:
    """Turn collected fixes (``GnssSink.rows``) into the flagged trajectory and frame curvature.

    Fixes that are not RTK fixed (``status < min_status``), have a horizontal variance above
    ``max_horizontal_var_m2`` or an invalid position are flagged and excluded; gaps longer than
    ``max_gap_s`` split the trajectory (see :mod:`superlane_tools.geo.curvature`).
    """
    n_frames = frame_t_ns.shape[0]
    nan = np.full(n_frames, np.nan)
    frame = pd.DataFrame(list(rows))
    if frame.empty:
        return RtkTruth(frame, nan, nan.copy(), nan.copy(), np.zeros(n_frames, bool), 0, 0, 0)
    frame = frame.sort_values("log_time_ns", kind="stable", ignore_index=True)
    good, reasons = _fix_quality(frame, config)
    t = frame["log_time_ns"].to_numpy(dtype=np.int64)
    east = np.full(len(frame), np.nan)
    north, up = east.copy(), east.copy()
    if good.any():
        lat = np.where(good, frame["latitude_deg"].to_numpy(dtype=np.float64), np.nan)
        enu = geodetic_to_enu(
            lat,
            frame["longitude_deg"].to_numpy(dtype=np.float64),
            frame["altitude_m"].to_numpy(dtype=np.float64),
        )
        east, north, up = enu.east_m, enu.north_m, enu.up_m
    gap_s = np.concatenate([[0.0], np.diff(t) / 1e9])
    dropout = gap_s > config.max_gap_s
    params = CurvatureParams(
        ds_m=config.ds_m,
        window_m=config.window_m,
        polyorder=config.polyorder,
        max_gap_s=config.max_gap_s,
        min_run_m=config.min_run_m,
    )
    at_fix = trajectory_curvature(t, east, north, good, t, params)
    at_frame = trajectory_curvature(t, east, north, good, frame_t_ns, params)
    good_t = t[good]
    valid = at_frame.valid.copy()
    if good_t.size:
        near = np.searchsorted(good_t, frame_t_ns)
        d_prev = np.abs(frame_t_ns - good_t[np.clip(near - 1, 0, good_t.size - 1)])
        d_next = np.abs(good_t[np.clip(near, 0, good_t.size - 1)] - frame_t_ns)
        valid &= np.minimum(d_prev, d_next) <= config.max_frame_gap_s * 1e9
    curvature = np.where(valid, at_frame.curvature_per_m, np.nan)
    fixes = pd.DataFrame(
        {
            "log_time_ns": t,
            "topic": frame["topic"].astype(str),
            "latitude_deg": frame["latitude_deg"].to_numpy(dtype=np.float64),
            "longitude_deg": frame["longitude_deg"].to_numpy(dtype=np.float64),
            "altitude_m": frame["altitude_m"].to_numpy(dtype=np.float64),
            "fix_status": frame["fix_status"].astype("Int8"),
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
    return RtkTruth(
        fixes,
        at_frame.s_m,
        at_frame.heading_rad,
        curvature,
        valid,
        int(good.sum()),
        int((~good).sum()),
        int(dropout.sum()),
    )
