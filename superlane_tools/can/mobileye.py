"""Mobileye lane messages: ego-line coefficients in the lane model's convention, by mapping.

Message and signal names and the sign/curvature conventions come from a
:class:`MobileyeMapping`. Two mappings ship: ``eyeq`` (the public EyeQ / 630 names of the
shared ``Mobileye.dbc`` and ``slt_mobileye_lanes.dbc``: ``Left_Lane_A`` ... with
``Curve_Parameter_C0..C3``) and ``lka`` (Apollo / AutonomouStuff ``LKA_Left_Lane_A`` ... with
``Position_Parameter_C0``, ``Heading_Angle_Parameter_C1``, ``Curvature_Parameter_C2``,
``Curvature_Derivative_Parameter_C3``). An update whose sides are all below the quality gate
(or missing) has no curvature (NaN), never 0.0.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

from superlane_tools.can.errors import CanError

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

PAIR_TOLERANCE_NS = 20_000_000
"""Part B of a lane message is paired with the part A at most this far away."""


@dataclass(frozen=True)
class MobileyeMapping:
    """Where a Mobileye unit's ego-lane values live on CAN, and their conventions.

    Attributes:
        left_a: Message with the left line's C0, C2, C3 and quality.
        left_b: Message with the left line's C1 and view range.
        right_a: Message with the right line's C0, C2, C3 and quality.
        right_b: Message with the right line's C1 and view range.
        c0: Lateral offset signal, metres.
        c1: Heading signal, radians.
        c2: Curvature signal (see ``c2_is_half_curvature``), 1/m.
        c3: Curvature-rate signal, 1/m^2.
        quality: Quality signal (0..3).
        view_range: View-range signal, metres.
        view_range_available: View-range validity flag ("" when the unit has none).
        right_positive: ``C0..C3`` are right positive (flipped into the left-positive model).
        c2_is_half_curvature: The lane polynomial is ``C0 + C1 x + C2 x^2 + C3 x^3``, so the
            curvature is ``2*C2`` (EyeQ); False when the ``C2`` signal is the curvature itself.
        min_quality: Sides below this quality do not count (NaN when no side reaches it).
        curvature_message: Message with a separate lane curvature (EyeQ 0x737 ``Lane``), "".
        curvature_signal: Its curvature signal (``Lane_Curvature``), 1/m, same sign as ``C2``.
    """

    left_a: str = "Left_Lane_A"
    left_b: str = "Left_Lane_B"
    right_a: str = "Right_Lane_A"
    right_b: str = "Right_Lane_B"
    c0: str = "Curve_Parameter_C0"
    c1: str = "Curve_Parameter_C1"
    c2: str = "Curve_Parameter_C2"
    c3: str = "Curve_Parameter_C3"
    quality: str = "Quality"
    view_range: str = "View_Range"
    view_range_available: str = "View_Range_Available"
    right_positive: bool = True
    c2_is_half_curvature: bool = True
    min_quality: int = 2
    curvature_message: str = "Lane"
    curvature_signal: str = "Lane_Curvature"


MAPPINGS: dict[str, MobileyeMapping] = {
    "eyeq": MobileyeMapping(),
    "lka": MobileyeMapping(
        left_a="LKA_Left_Lane_A",
        left_b="LKA_Left_Lane_B",
        right_a="LKA_Right_Lane_A",
        right_b="LKA_Right_Lane_B",
        c0="Position_Parameter_C0",
        c1="Heading_Angle_Parameter_C1",
        c2="Curvature_Parameter_C2",
        c3="Curvature_Derivative_Parameter_C3",
        view_range_available="View_range_availability",
        curvature_message="",
        curvature_signal="",
    ),
}
"""Shipped mappings: ``eyeq`` (public EyeQ / 630 names) and ``lka`` (Apollo/AutonomouStuff)."""


def mapping(name: str, right_positive: bool | None = None) -> MobileyeMapping:
    """Return a shipped mapping by name, optionally with its sign convention overridden.

    Raises:
        CanError: For an unknown name.
    """
    if name not in MAPPINGS:
        raise CanError(f"unknown Mobileye mapping {name!r}; shipped: {', '.join(MAPPINGS)}")
    base = MAPPINGS[name]
    if right_positive is None or right_positive == base.right_positive:
        return base
    from dataclasses import replace

    return replace(base, right_positive=right_positive)


def _wide(signals: pd.DataFrame, message: str) -> pd.DataFrame:
    rows = signals[signals["message"] == message] if message else signals.iloc[0:0]
    if rows.empty:
        return pd.DataFrame({"log_time_ns": pd.Series(dtype=np.int64)})
    wide = rows.pivot_table(
        index="log_time_ns", columns="signal", values="value", aggfunc="last", observed=True
    )
    wide.columns = [str(c) for c in wide.columns]
    return wide.reset_index().sort_values("log_time_ns", ignore_index=True)


def _column(df: pd.DataFrame, name: str, times: IntArray) -> FloatArray:
    """Values of ``name`` nearest to ``times`` (within the pairing tolerance), NaN elsewhere."""
    out = np.full(times.shape, np.nan)
    if not name or name not in df.columns or df.empty:
        return out
    src_t = df["log_time_ns"].to_numpy(dtype=np.int64)
    src_v = df[name].to_numpy(dtype=np.float64)
    idx = np.clip(np.searchsorted(src_t, times), 1, max(src_t.size - 1, 1))
    lo = np.clip(idx - 1, 0, src_t.size - 1)
    hi = np.clip(idx, 0, src_t.size - 1)
    pick = np.where(np.abs(times - src_t[lo]) <= np.abs(src_t[hi] - times), lo, hi)
    near = np.abs(src_t[pick] - times) <= PAIR_TOLERANCE_NS
    out[near] = src_v[pick][near]
    return out


CORRIDOR_WIDTH_AT_M = 10.0
"""Default distance ahead of Mobileye's corridor width, metres (``kpi.width_at_m``)."""


def mobileye_table(
    signals: pd.DataFrame,
    spec: MobileyeMapping | None = None,
    width_at_m: float = CORRIDOR_WIDTH_AT_M,
) -> pd.DataFrame:
    """Build one row per Mobileye lane update: both ego lines in the lane model's convention.

    Coefficients become ``y = a0 + a1 x + a2 x^2 + a3 x^3`` with ``y`` left positive (for a
    right-positive unit ``a_k = -C_k``). Curvature per side is ``2 * a2`` (or ``a2`` when the
    unit's C2 is the curvature), 1/m, left positive. ``curvature`` is the mean over the sides
    with quality >= ``min_quality``; NaN when no side qualifies (an invalid update is missing,
    not a straight road). ``lane_curvature`` is the separate curvature message (EyeQ 0x737)
    in the same convention, for a cross-check of C2 (NaN when absent).

    Args:
        signals: Decoded CAN signals (``message``, ``signal``, ``value``, ``log_time_ns``).
        spec: The mapping (default: ``eyeq``).
        width_at_m: Distance ahead of the corridor width, metres (at the view range when that is
            nearer), as for the other availability methods.

    Returns:
        Columns ``log_time_ns`` and, per side ``left``/``right``: ``{side}_a0_m``,
        ``{side}_a1_rad``, ``{side}_a2_per_m``, ``{side}_a3_per_m2``, ``{side}_quality``,
        ``{side}_view_range_m``, ``{side}_curvature``; then ``curvature``,
        ``lane_curvature``, ``corridor_width_m`` (between the lines ``width_at_m`` ahead) and
        ``corridor_length_m`` (shorter view range), NaN unless both lines pass the quality
        gate. Empty when the recording has no Mobileye lane messages.
    """
    m = spec or MobileyeMapping()
    sign = -1.0 if m.right_positive else 1.0
    k_factor = 2.0 if m.c2_is_half_curvature else 1.0
    sides: dict[str, pd.DataFrame] = {}
    for side, (msg_a, msg_b) in {
        "left": (m.left_a, m.left_b),
        "right": (m.right_a, m.right_b),
    }.items():
        part_a = _wide(signals, msg_a)
        if part_a.empty:
            continue
        part_b = _wide(signals, msg_b)
        t_a = part_a["log_time_ns"].to_numpy(dtype=np.int64)
        frame = pd.DataFrame({"log_time_ns": t_a})
        frame[f"{side}_a0_m"] = sign * _column(part_a, m.c0, t_a)
        frame[f"{side}_a1_rad"] = sign * _column(part_b, m.c1, t_a)
        frame[f"{side}_a2_per_m"] = sign * _column(part_a, m.c2, t_a)
        frame[f"{side}_a3_per_m2"] = sign * _column(part_a, m.c3, t_a)
        frame[f"{side}_quality"] = _column(part_a, m.quality, t_a)
        view = _column(part_b, m.view_range, t_a)
        if m.view_range_available:
            avail = _column(part_b, m.view_range_available, t_a)
            view = np.where(avail == 0, np.nan, view)
        frame[f"{side}_view_range_m"] = view
        frame[f"{side}_curvature"] = k_factor * frame[f"{side}_a2_per_m"]
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
                tolerance=PAIR_TOLERANCE_NS,
            )
        )
    assert merged is not None
    merged["curvature"] = _mean_of_good(merged, list(sides), m.min_quality)
    width, length = _corridor(merged, m.min_quality, width_at_m)
    merged["corridor_width_m"] = width
    merged["corridor_length_m"] = length
    lane = _wide(signals, m.curvature_message)
    t = merged["log_time_ns"].to_numpy(dtype=np.int64)
    merged["lane_curvature"] = sign * _column(lane, m.curvature_signal, t)
    return merged.reset_index(drop=True)


def _corridor(merged: pd.DataFrame, min_quality: int, at_m: float) -> tuple[FloatArray, FloatArray]:
    """Mobileye's ego corridor: width between its lines at ``at_m`` ahead, length = view range.

    NaN (no corridor) unless both lines have quality >= ``min_quality``; the length is the
    shorter of the two view ranges. Mobileye's polynomials and view ranges are referred to its own
    camera, taken to sit at the vehicle-frame origin of the other methods. Where the view range
    is shorter than ``at_m`` the width is taken at the view range, as for the other methods.
    """
    n = len(merged)
    if not {"left_a0_m", "right_a0_m"} <= set(merged.columns):
        return np.full(n, np.nan), np.full(n, np.nan)

    length = np.fmin(
        merged["left_view_range_m"].to_numpy(dtype=np.float64),
        merged["right_view_range_m"].to_numpy(dtype=np.float64),
    )
    x = np.where(np.isfinite(length), np.fmin(at_m, length), at_m)

    def at(side: str) -> FloatArray:
        a0, a1, a2, a3 = (
            merged[f"{side}_{k}"].to_numpy(dtype=np.float64)
            for k in ("a0_m", "a1_rad", "a2_per_m", "a3_per_m2")
        )
        cubic: FloatArray = a0 + x * (np.nan_to_num(a1) + x * (a2 + x * np.nan_to_num(a3)))
        return cubic

    ok = (merged["left_quality"].to_numpy() >= min_quality) & (
        merged["right_quality"].to_numpy() >= min_quality
    )
    width = np.where(ok, at("left") - at("right"), np.nan)
    return width, np.where(ok, length, np.nan)


def _mean_of_good(merged: pd.DataFrame, sides: list[str], min_quality: int) -> FloatArray:
    """Mean curvature over sides with quality >= ``min_quality``; NaN where none qualifies."""
    curv = np.stack([merged[f"{s}_curvature"].to_numpy(dtype=np.float64) for s in sides], axis=1)
    qual = np.stack([merged[f"{s}_quality"].to_numpy(dtype=np.float64) for s in sides], axis=1)
    with np.errstate(invalid="ignore"):
        good = np.isfinite(curv) & (qual >= min_quality)
    count = good.sum(axis=1)
    total = np.where(good, curv, 0.0).sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(count > 0, total / np.maximum(count, 1), np.nan)


class Latency(NamedTuple):
    """A delay estimate by cross-correlation.

    Attributes:
        lag_s: How much later the signal follows the reference, seconds (NaN if unknown).
        correlation: Normalised correlation at that lag.
        sharpness: How much the correlation drops one ``resolution_s`` either side of the peak,
            in units of the misfit ``1 - correlation`` (NaN if unknown). Below 1 the series hold
            too little timing information for that resolution (slow, noise-sized motion only):
            the lag is then not resolved.
        n: Signal samples that overlapped the reference at that lag.
        unresolved: Why the data do not pin the lag ("" when nothing but the sharpness says so;
            see :func:`line_latency`).
    """

    lag_s: float
    correlation: float
    sharpness: float = float("nan")
    n: int = 0
    unresolved: str = ""

    @property
    def resolved(self) -> bool:
        """Whether the lag is resolved to ``resolution_s``: sharp, and no other reason against."""
        return bool(self.sharpness >= 1.0) and not self.unresolved


MAX_LAGS = 1001
"""Most lags one latency search evaluates (the grid step grows for long searches)."""

Series = tuple[NDArray[np.float64], NDArray[np.float64]]


def _channels(times: ArrayLike, values: ArrayLike) -> list[Series]:
    """Split ``(N,)`` or ``(N, k)`` samples into k finite series ``(t, v)``."""
    t = np.asarray(times, dtype=np.float64)
    v = np.asarray(values, dtype=np.float64)
    v = v[:, None] if v.ndim == 1 else v
    if v.ndim != 2 or v.shape[0] != t.shape[0]:
        raise CanError(f"need one value (or row) per time, got {t.shape} and {v.shape}")
    out = []
    for k in range(v.shape[1]):
        good = np.isfinite(t) & np.isfinite(v[:, k])
        out.append((t[good], v[good, k]))
    return out


def _pooled_correlation(refs: list[Series], sigs: list[Series], lag_s: float) -> tuple[float, int]:
    """Pearson correlation of the signals with the references shifted by ``lag_s``, pooled."""
    sab = saa = sbb = 0.0
    count = 0
    for (t_ref, ref), (t_sig, sig) in zip(refs, sigs, strict=True):
        if t_ref.size < 2:
            continue
        r = np.interp(t_sig - lag_s, t_ref, ref, left=np.nan, right=np.nan)
        ok = np.isfinite(r)
        if ok.sum() < 3:
            continue
        a, b = r[ok] - r[ok].mean(), sig[ok] - sig[ok].mean()
        sab, saa, sbb = sab + float(a @ b), saa + float(a @ a), sbb + float(b @ b)
        count += int(ok.sum())
    if count < 10 or not saa * sbb > 0:
        return float("nan"), count
    return sab / float(np.sqrt(saa * sbb)), count


def latency_by_xcorr(
    t_ref_s: ArrayLike,
    reference: ArrayLike,
    t_sig_s: ArrayLike,
    signal: ArrayLike,
    max_lag_s: float = 0.5,
    step_s: float = 0.005,
    resolution_s: float = 1.0 / 15.0,
) -> Latency:
    """Estimate how far ``signal`` lags ``reference`` by cross-correlating them.

    Each series keeps its own time base, so the lag is not limited to the camera's frame period:
    for every lag ``L`` on a grid of ``step_s`` in ``[-max_lag_s, max_lag_s]`` the reference is
    interpolated (linearly) at ``t_sig - L`` and correlated with the signal (Pearson, each
    channel demeaned over its overlap, the channels pooled); the best grid lag is refined by a
    parabola through its neighbours. The grid holds at most :data:`MAX_LAGS` lags, so the search
    is bounded whatever the time stamps. NaN samples are left out; reference samples sharing a
    time stamp (batched bridges) keep the first. The result's ``sharpness`` says whether the
    series resolve the lag to ``resolution_s`` (e.g. one camera frame period).

    Args:
        t_ref_s: ``(N,)`` reference sample times, seconds.
        reference: ``(N,)`` or ``(N, k)`` reference, measured without delay (e.g. the camera
            frames' own lane-line offsets).
        t_sig_s: ``(M,)`` signal sample times, seconds (e.g. Mobileye's CAN log times).
        signal: ``(M,)`` or ``(M, k)``: the delayed signal, the same quantities as the reference.
        max_lag_s: Largest lag searched either way, seconds.
        step_s: Lag grid step, seconds.
        resolution_s: The resolution the estimate is judged at, seconds.

    Returns:
        The lag (seconds, positive: the signal comes later) with the highest correlation; NaN
        with fewer than 10 overlapping samples or constant series.

    Raises:
        CanError: If times and values do not match or the channel counts differ.
    """
    nan = Latency(float("nan"), float("nan"))
    refs = []
    for t_ref, ref in _channels(t_ref_s, reference):
        order = np.argsort(t_ref, kind="stable")
        t_unique, first = np.unique(t_ref[order], return_index=True)
        refs.append((t_unique, ref[order][first]))
    sigs = _channels(t_sig_s, signal)
    if len(refs) != len(sigs):
        raise CanError(f"reference has {len(refs)} channels, signal {len(sigs)}")
    if not max_lag_s > 0 or not step_s > 0:
        return nan
    step = max(step_s, 2.0 * max_lag_s / (MAX_LAGS - 1))
    half = int(max_lag_s / step)
    lags = step * np.arange(-half, half + 1)
    corr = np.array([_pooled_correlation(refs, sigs, float(lag))[0] for lag in lags])
    if not np.isfinite(corr).any():
        return nan
    best = int(np.nanargmax(corr))
    lag = float(lags[best])
    if 0 < best < lags.size - 1 and np.isfinite(corr[best - 1 : best + 2]).all():
        c_m, c_0, c_p = corr[best - 1], corr[best], corr[best + 1]
        bend = c_m - 2 * c_0 + c_p
        if bend < 0:
            lag += step * 0.5 * (c_m - c_p) / bend
    peak, n = _pooled_correlation(refs, sigs, lag)
    if not np.isfinite(peak) or peak < corr[best]:
        peak, n = float(corr[best]), _pooled_correlation(refs, sigs, float(lags[best]))[1]
    sides = [_pooled_correlation(refs, sigs, lag + d)[0] for d in (-resolution_s, resolution_s)]
    drop = peak - float(np.nanmean(sides)) if np.isfinite(sides).any() else float("nan")
    sharpness = drop / max(1.0 - peak, 1e-9)
    return Latency(lag, peak, sharpness, n)


RELABEL_STEP_M = 1.0
"""A jump of a line offset between two updates larger than this (m) is an ego-line relabelling.

At 15 Hz a lane change moves the vehicle about 0.1 m between frames; a jump of a lane width
(~3.5 m) is the moment a system calls the next line "ego", which each system decides by its
own rule, not by its latency."""


def unwrap_relabels(values: ArrayLike, max_step_m: float = RELABEL_STEP_M) -> FloatArray:
    """Remove ego-line relabellings from ``(N,)`` or ``(N, k)`` line offsets (time-ordered).

    Steps between consecutive finite samples larger than ``max_step_m`` are taken out, so a lane
    change becomes the continuous lateral motion it is; NaN samples stay NaN.
    """
    out = np.array(values, dtype=np.float64, copy=True)
    cols = out.reshape(out.shape[0], -1)
    for k in range(cols.shape[1]):
        finite = np.isfinite(cols[:, k])
        v = cols[finite, k]
        if v.size < 2:
            continue
        steps = np.diff(v)
        steps[np.abs(steps) > max_step_m] = 0.0
        cols[finite, k] = v[0] + np.concatenate([[0.0], np.cumsum(steps)])
    return out


def line_latency(
    t_ref_s: ArrayLike,
    reference: ArrayLike,
    t_sig_s: ArrayLike,
    signal: ArrayLike,
    resolution_s: float,
    max_lag_s: float = 0.5,
) -> Latency:
    """Estimate a lane system's latency from line offsets, claiming it only when the data pin it.

    The offsets are unwrapped first (:func:`unwrap_relabels`): the instant a system relabels its
    ego lines during a lane change is a step of a lane width whose timing follows that system's
    switching rule, not its latency, and one such step dominated the correlation (a 10 s
    simulated drive with one lane change gave +0.169 s "resolved" for a delay of 0.1 s). The lag
    is then resolved to ``resolution_s`` only when both hold:

    1. *sharp*: the correlation drops by at least the misfit ``1 - correlation`` one
       ``resolution_s`` either side of the peak (``sharpness >= 1``), i.e. the lateral motion has
       energy at the frame period's time scale, not only slow wander;
    2. *repeated*: each half of the drive on its own gives a sharp peak within ``resolution_s``
       of the whole drive's lag, so the lag is not set by a single event.

    Returns:
        The whole drive's estimate, with ``unresolved`` saying why it is not resolved.

    Raises:
        CanError: If times and values do not match or the channel counts differ.
    """
    t_ref = np.asarray(t_ref_s, dtype=np.float64)
    t_sig = np.asarray(t_sig_s, dtype=np.float64)
    ref = unwrap_relabels(reference)
    sig = unwrap_relabels(signal)
    whole = latency_by_xcorr(t_ref, ref, t_sig, sig, max_lag_s, resolution_s=resolution_s)
    if not np.isfinite(whole.lag_s):
        return whole._replace(unresolved="too few overlapping line offsets")
    if not whole.sharpness >= 1.0:
        return whole._replace(
            unresolved="the correlation peak is flat at one frame period: too little lateral "
            "motion (lane changes, weaving) for a timing reference"
        )
    mid = 0.5 * (t_ref.min() + t_ref.max())
    halves = []
    for part_ref, part_sig in ((t_ref < mid, t_sig < mid), (t_ref >= mid, t_sig >= mid)):
        part = latency_by_xcorr(
            t_ref[part_ref],
            ref[part_ref],
            t_sig[part_sig],
            sig[part_sig],
            max_lag_s,
            resolution_s=resolution_s,
        )
        halves.append(part)
    agree = all(h.sharpness >= 1.0 and abs(h.lag_s - whole.lag_s) <= resolution_s for h in halves)
    if not agree:
        said = ", ".join(f"{h.lag_s:+.3f} s (sharpness {h.sharpness:.2f})" for h in halves)
        return whole._replace(
            unresolved=f"not repeated over the drive: its halves give {said}; the lag rests "
            "on a single lateral event"
        )
    return whole
