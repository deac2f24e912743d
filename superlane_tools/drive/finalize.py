"""After the streaming pass: a drive's record plus CAN/GNSS -> its tables and report sections.

:func:`drive_tables` is pure (arrays and parameters in, tables and notes out);
:func:`report_sections` says what the report states; the command writes both.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from superlane_tools.can import (
    MAPPINGS,
    Latency,
    LoadedDbc,
    MobileyeMapping,
    latency_by_xcorr,
    mobileye_table,
)
from superlane_tools.can.collect import CanFrames
from superlane_tools.can.errors import CanError
from superlane_tools.corridor import (
    AvailabilityParams,
    Segment,
    TimeSegment,
    segments_at_times,
    windows,
)
from superlane_tools.drive.config import ReprocessConfig, TrackingConfig, load_manifest
from superlane_tools.drive.record import DriveFrames, FitSeries
from superlane_tools.drive.signals import (
    ImuSamples,
    RtkTruth,
    Series,
    at_frames,
    can_frame_signals,
    dynamics_reference,
    gnss_speed,
    mobileye_at_frames,
    rtk_truth,
)
from superlane_tools.geo import DEGRADED_NOTE
from superlane_tools.geo.dynamics import DynamicsCurvature
from superlane_tools.lanes.lookahead import align_super_curvature, smooth_like_truth
from superlane_tools.lanes.tracker import COV_INDEX, COV_KEYS, track_lanes, travelled_m
from superlane_tools.records import Skipped
from superlane_tools.reporting import drive_tables as tables
from superlane_tools.reporting.gnss_sink import GnssFixes
from superlane_tools.reporting.headline import headline_table
from superlane_tools.reporting.report import Section


@dataclass(frozen=True)
class DriveTables:
    """The tables derived from a drive after the streaming pass, and what the report states.

    Attributes:
        can_signals: Decoded CAN signals (long format).
        mobileye: One row per Mobileye lane update.
        rtk: One row per GNSS fix, flagged.
        curvature: One row per frame: SUPER, tracked and Mobileye curvature against RTK.
        curvature_summary: Curvature errors overall and per sequence.
        availability_frames: Availability per frame and method.
        availability_sequences: Availability per sequence and method.
        notes: Missing streams and fallbacks.
        lost: Input that could not be used (e.g. no CAN id matched by any DBC).
    """

    can_signals: pd.DataFrame
    mobileye: pd.DataFrame
    rtk: pd.DataFrame
    curvature: pd.DataFrame
    curvature_summary: pd.DataFrame
    availability_frames: pd.DataFrame
    availability_sequences: pd.DataFrame
    notes: tuple[str, ...]
    lost: tuple[Skipped, ...] = ()


def kpi_segments(
    config: ReprocessConfig, t_ns: np.ndarray, fps: float, given: Sequence[TimeSegment] | None
) -> list[Segment]:
    """Return the KPI sequences as frame ranges: given, from the manifest, or windows."""
    if given is None and config.kpi.manifest:
        given = load_manifest(config.kpi.manifest)
    if given is not None:
        return segments_at_times(t_ns, given)
    size = max(1, round(config.kpi.window_s * fps))
    return [Segment(s.start, s.stop, config.kpi.category) for s in windows(len(t_ns), size)]


def drive_tables(
    frames: DriveFrames,
    can: CanFrames,
    dbcs: Mapping[str, LoadedDbc],
    gnss: GnssFixes,
    config: ReprocessConfig,
    segments: Sequence[Segment],
    params: AvailabilityParams,
    corridor_unavailable: str,
    imu: ImuSamples | None = None,
    camera: bool = True,
) -> DriveTables:
    """Turn a drive's per-frame record plus its CAN frames and GNSS fixes into its tables.

    The steps: the vehicle's signals and the truth at the frames, Mobileye's lanes, the
    yaw-rate / speed reference, the curvature table and its summary, then availability.

    Raises:
        CanError: If a used CAN signal has no or an unknown unit, or the Mobileye mapping is
            unknown.
    """
    t_ns = frames.t_ns
    notes: list[str] = []
    lost: list[Skipped] = []
    vehicle = _vehicle_signals(can, dbcs, gnss, t_ns, config, notes, lost)
    me, mapping = _mobileye(vehicle.signals, config, has_can=bool(len(can)), notes=notes)
    notes += _truth_notes(vehicle.rtk, config)
    dyn = _dynamics(vehicle, imu, t_ns, config, notes)
    curv = _curvature_table(frames, vehicle, me, dyn, config, notes)
    latency, latency_line = mobileye_latency(frames.fit, me, t_ns, mapping.min_quality)
    if latency_line:
        notes.append(latency_line)
    summary = _curvature_summary(curv, segments, vehicle.rtk, latency)
    av_frames, av_seqs = _availability(
        frames, me, vehicle.speed, params, segments, corridor_unavailable, camera
    )
    return DriveTables(
        vehicle.signals,
        me,
        vehicle.rtk.fixes,
        curv,
        summary,
        av_frames,
        av_seqs,
        tuple(notes),
        tuple(lost),
    )


@dataclass(frozen=True)
class _Vehicle:
    """The vehicle's signals: decoded CAN, speed and yaw rate (series and at the frames), truth."""

    signals: pd.DataFrame
    speed_s: Series | None
    yaw_s: Series | None
    speed: NDArray[np.float64]
    yaw: NDArray[np.float64]
    rtk: RtkTruth


def _vehicle_signals(
    can: CanFrames,
    dbcs: Mapping[str, LoadedDbc],
    gnss: GnssFixes,
    t_ns: NDArray[np.int64],
    config: ReprocessConfig,
    notes: list[str],
    lost: list[Skipped],
) -> _Vehicle:
    """Decode CAN (noting the DBC coverage), pick speed and yaw rate, build the RTK truth."""
    signals = can.decode(dbcs)
    if len(can):
        coverage = can.coverage(dbcs)
        notes.append(coverage.line())
        if coverage.none_matched:
            detail = f"no CAN id matched by any DBC: 0 of {coverage.seen} ids (wrong DBC?)"
            lost.append(Skipped("CAN signals", detail, coverage.seen))
    speed_s, yaw_s = can_frame_signals(signals, config.can)
    rtk = rtk_truth(gnss, t_ns, config.rtk, speed_s)
    if speed_s is None and (fallback := gnss_speed(rtk)) is not None:
        speed_s = fallback
        notes.append("speed: no CAN speed, estimated from the GNSS fixes")
    if not len(can):
        notes.append(
            "no CAN stream: speed unknown, availability by length marked unknown; "
            "no Mobileye comparison"
        )
    elif speed_s is None:
        notes.append(
            f"no CAN speed signal {config.can.speed_signal!r}: availability by length "
            "marked unknown"
        )
    speed, yaw = at_frames(speed_s, t_ns), at_frames(yaw_s, t_ns)
    return _Vehicle(signals, speed_s, yaw_s, speed, yaw, rtk)


def _mobileye(
    signals: pd.DataFrame, config: ReprocessConfig, has_can: bool, notes: list[str]
) -> tuple[pd.DataFrame, MobileyeMapping]:
    """Return Mobileye's lane updates from the decoded CAN, and the mapping used."""
    if config.can.mobileye_mapping not in MAPPINGS:
        raise CanError(
            f"unknown can.mobileye_mapping {config.can.mobileye_mapping!r}; "
            f"shipped: {', '.join(MAPPINGS)}"
        )
    mapping = replace(
        MAPPINGS[config.can.mobileye_mapping], right_positive=config.can.mobileye_right_positive
    )
    me = mobileye_table(signals, mapping, config.kpi.width_at_m)
    if has_can and me.empty:
        notes.append("no Mobileye lane messages on CAN: no Mobileye comparison")
    return me, mapping


def _dynamics(
    vehicle: _Vehicle,
    imu: ImuSamples | None,
    t_ns: NDArray[np.int64],
    config: ReprocessConfig,
    notes: list[str],
) -> DynamicsCurvature | None:
    """Return the yaw-rate / speed curvature reference (the IMU's yaw rate without CAN's)."""
    yaw_s = vehicle.yaw_s
    if yaw_s is None and imu is not None and len(imu):
        yaw_s = imu.yaw_series(config.rtk.imu_yaw_axis)
        notes.append(f"yaw rate: IMU gyro about {config.rtk.imu_yaw_axis}")
    dyn = dynamics_reference(yaw_s, vehicle.speed_s, t_ns, config.rtk)
    if dyn is None:
        notes.append("no yaw-rate / speed reference: no dynamics curvature cross-check")
    else:
        notes.append(f"yaw-rate reference: gyro bias {dyn.bias.rps:.2e} rad/s ({dyn.bias.source})")
    return dyn


def _curvature_table(
    frames: DriveFrames,
    vehicle: _Vehicle,
    me: pd.DataFrame,
    dyn: DynamicsCurvature | None,
    config: ReprocessConfig,
    notes: list[str],
) -> pd.DataFrame:
    """One row per frame: the truth, SUPER (raw, aligned, tracked), Mobileye, the dynamics."""
    t_ns, fit, rtk = frames.t_ns, frames.fit, vehicle.rtk
    curv = pd.DataFrame(
        {
            "frame_index": np.arange(len(t_ns), dtype=np.int32),
            "log_time_ns": t_ns,
            "t_s": (t_ns - (t_ns[0] if len(t_ns) else 0)) / 1e9,
            "s_m": rtk.frame_s_m,
            "speed_mps": vehicle.speed,
            "yaw_rate_rps": vehicle.yaw,
            "rtk_curvature": rtk.frame_curvature,
            "rtk_valid": rtk.frame_valid,
            "super_curvature": fit.curvature_per_m,
            "mobileye_curvature": mobileye_at_frames(me, t_ns),
            "dynamics_curvature": (
                dyn.curvature_per_m if dyn is not None else np.full(len(t_ns), np.nan)
            ),
        }
    )
    aligned = align_super_curvature(
        rtk.frame_s_m,
        fit.curvature_per_m,
        fit.lookahead_m,
        fit.centre_m,
        fit.lane_width_m,
        window_m=config.rtk.window_m,
        ds_m=config.rtk.ds_m,
    )
    curv["super_lookahead_m"] = fit.lookahead_m
    curv["super_lateral_m"] = aligned.lateral_m
    curv["super_road_sg_curvature"] = aligned.road_per_m
    curv["super_lateral_sg_curvature"] = aligned.lateral_per_m
    curv["super_path_sg_curvature"] = aligned.path_per_m
    _add_track(curv, frames, config, notes)
    _add_fair_mobileye(curv, me, t_ns, config, notes)
    return curv


def _curvature_summary(
    curv: pd.DataFrame, segments: Sequence[Segment], rtk: RtkTruth, latency: Latency | None
) -> pd.DataFrame:
    """Add the error columns to ``curv``; return the errors overall and per sequence."""
    curv["super_error"] = curv["super_curvature"] - curv["rtk_curvature"]
    curv["super_path_error"] = curv["super_path_curvature"] - curv["rtk_curvature"]
    curv["mobileye_error"] = curv["mobileye_curvature"] - curv["rtk_curvature"]
    summary = tables.curvature_summary(curv, segments)
    summary["truth_noise_floor_per_m"] = rtk.noise_floor_per_m
    summary["truth_degraded"] = rtk.degraded
    summary["mobileye_latency_s"] = latency.lag_s if latency is not None else np.nan
    summary["mobileye_latency_resolved"] = latency is not None and latency.resolved
    return summary


def _availability(
    frames: DriveFrames,
    me: pd.DataFrame,
    speed: NDArray[np.float64],
    params: AvailabilityParams,
    segments: Sequence[Segment],
    corridor_unavailable: str,
    camera: bool,
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Availability of every method per frame and per sequence."""
    t_ns = frames.t_ns
    unavailable = {"corridor_net": corridor_unavailable} if corridor_unavailable else {}
    if me.empty:
        unavailable["mobileye"] = "no Mobileye lane messages"
    if not camera:
        unavailable.update(dict.fromkeys(IMAGE_METHODS, "no camera stream"))
    geometry = {
        **frames.corridors.by_method(),
        "mobileye": (
            mobileye_at_frames(me, t_ns, "corridor_width_m"),
            mobileye_at_frames(me, t_ns, "corridor_length_m"),
        ),
    }
    av_frames, av_seqs, _ = tables.availability_tables(
        t_ns, geometry, unavailable, speed, params, segments
    )
    return av_frames, av_seqs


IMAGE_METHODS = ("super", "corridor_net", "hough")
"""Availability methods that need camera frames."""


def _truth_notes(rtk: Any, config: ReprocessConfig) -> list[str]:
    """What the report says about the truth: missing, degraded, gated, its noise floor."""
    if rtk.fixes.empty:
        return ["no GNSS/RTK stream: no curvature ground truth"]
    notes = []
    if rtk.degraded:
        notes.append(f"{DEGRADED_NOTE}: plain GNSS fixes only (no RTK fixed fix)")
    if rtk.n_degraded or rtk.n_dropouts:
        notes.append(
            f"RTK: {rtk.n_degraded} degraded fixes flagged and excluded, "
            f"{rtk.n_dropouts} dropouts > {config.rtk.max_gap_s} s"
        )
    notes.append(
        f"truth: no sample below {config.rtk.min_speed_mps} m/s ({rtk.n_slow} fixes while "
        f"standing or crawling); fixes decimated to >= {config.rtk.min_step_m} m steps; "
        f"noise floor {_fmt(rtk.noise_floor_per_m)} 1/m"
    )
    return notes


def _fmt(value: float) -> str:
    return "unknown" if not np.isfinite(value) else f"{value:.2e}"


def _add_fair_mobileye(
    curv: pd.DataFrame,
    me: pd.DataFrame,
    t_ns: np.ndarray,
    config: ReprocessConfig,
    notes: list[str],
) -> None:
    """Give Mobileye SUPER's treatment: same smoothing and manoeuvre term, beside the raw value.

    Mobileye's ``2*C2`` describes the road at the vehicle (placement 0 m ahead); its own
    ``C0`` of both lines gives the lateral position in the lane, as SUPER's fit does.
    """
    s_m = curv["s_m"].to_numpy(dtype=np.float64)
    raw = curv["mobileye_curvature"].to_numpy(dtype=np.float64)
    left = mobileye_at_frames(me, t_ns, "left_a0_m")
    right = mobileye_at_frames(me, t_ns, "right_a0_m")
    fair = align_super_curvature(
        s_m,
        raw,
        np.zeros(len(t_ns)),
        0.5 * (left + right),
        left - right,
        window_m=config.rtk.window_m,
        ds_m=config.rtk.ds_m,
    )
    curv["mobileye_path_curvature"] = fair.path_per_m
    if np.isfinite(raw).any():
        lane = mobileye_at_frames(me, t_ns, "lane_curvature")
        both = np.isfinite(lane) & np.isfinite(raw)
        if both.any():
            rms = float(np.sqrt(np.mean((lane[both] - raw[both]) ** 2)))
            notes.append(f"Mobileye 0x737 Lane_Curvature vs 2*C2: RMS difference {rms:.2e} 1/m")


def mobileye_latency(
    fit: FitSeries, me: pd.DataFrame, t_ns: NDArray[np.int64], min_quality: int
) -> tuple[Latency | None, str]:
    """Estimate Mobileye's latency behind the camera frames and say it in one report line.

    The signal is the lateral offset of Mobileye's two ego lines at the vehicle (``C0``, updates
    of quality >= ``min_quality``, at their own CAN log times); the reference is the same two
    offsets measured by the SUPER fit on each camera frame, which has no delay by construction.
    The offsets are placement-free: Mobileye's curvature against the RTK path curvature mixes the
    latency with where its ``C2`` describes the road (its cubic is fitted over tens of metres
    ahead), which on simulated drives moved the estimate from +0.1 s to about -0.1 s. The lag is
    resolved to one frame period only when the drive has sharp lateral features (lane changes);
    with nothing but slow centimetre wander the line says so instead of quoting a number.
    """
    if me.empty or "left_a0_m" not in me or "right_a0_m" not in me:
        return None, ""
    if not (np.isfinite(fit.left_m).any() and np.isfinite(fit.right_m).any()):
        return None, (
            "Mobileye latency: not estimated (needs the camera frames' own lane-line offsets as "
            "the time reference; curvature against the RTK truth confounds latency with where "
            "Mobileye's C2 measures the road)"
        )
    steps = np.diff(t_ns)
    steps = steps[steps > 0]  # frames may share a log time (batched bridges)
    if steps.size == 0:
        return None, "Mobileye latency: not estimated (frame times do not advance)"
    period = float(np.median(steps)) / 1e9
    t0 = int(t_ns[0])
    me_t = (me["log_time_ns"].to_numpy(dtype=np.int64) - t0) / 1e9
    offsets = np.stack(
        [
            np.where(me[f"{side}_quality"].to_numpy() >= min_quality, me[f"{side}_a0_m"], np.nan)
            for side in ("left", "right")
        ],
        axis=1,
    )
    lag = latency_by_xcorr(
        (t_ns - t0) / 1e9,
        np.stack([fit.left_m, fit.right_m], axis=1),
        me_t,
        offsets,
        resolution_s=period,
    )
    if not np.isfinite(lag.lag_s):
        return lag, "Mobileye latency: not estimated (too few overlapping line offsets)"
    head = (
        f"Mobileye latency behind the camera frames, by cross-correlation of its ego lines' "
        f"offsets (C0) with SUPER's: {lag.lag_s:+.3f} s (correlation {lag.correlation:.2f}, "
        f"sharpness {lag.sharpness:.2f}"
    )
    if lag.resolved:
        return lag, f"{head}; resolved to one frame period, {period:.3f} s)"
    return lag, (
        f"{head} < 1): NOT resolved to one frame period ({period:.3f} s) on this drive: too "
        "little lateral motion (no lane change) for a timing reference"
    )


@dataclass(frozen=True)
class ReportFacts:
    """What the report states about the run besides the tables.

    Attributes:
        recording: The input recording.
        n_frames: Frames processed.
        backend_name: Segmentation backend used.
        corridor_unavailable: Why the corridor network is unavailable ("" when available).
        notes: Missing streams and fallbacks, in order.
        skipped: What was lost.
    """

    recording: Path
    n_frames: int
    backend_name: str
    corridor_unavailable: str
    notes: tuple[str, ...]
    skipped: tuple[Skipped, ...]


def _add_track(
    curv: pd.DataFrame, frames: DriveFrames, config: ReprocessConfig, notes: list[str]
) -> None:
    """Add the tracked SUPER curvature; set ``super_road`` / ``super_path`` from it (or SG)."""
    trk = config.tracking
    fit = frames.fit
    s_trk = travelled_m(curv["log_time_ns"].to_numpy(), curv["speed_mps"].to_numpy())
    if trk.enabled and not np.isfinite(s_trk).any():
        s_trk = curv["s_m"].to_numpy(dtype=np.float64)
        notes.append("lane tracker: no CAN speed, travelled distance from the RTK track")
    curv["super_travelled_m"] = s_trk
    # The tracker's inputs, kept so that a track can be audited (or re-run) from the table.
    curv["super_fit_a1"] = fit.heading_rad
    curv["super_fit_b"] = fit.slope
    curv["super_fit_near_m"] = fit.near_m
    curv["super_fit_far_m"] = fit.far_m
    curv["super_fit_trackable"] = fit.trackable.astype(np.float64)
    for key, (i, j) in zip(COV_KEYS, COV_INDEX, strict=True):
        curv[key] = fit.cov[:, i, j]
    chosen = "sg"
    if trk.enabled and np.isfinite(s_trk).sum() >= 2:
        track = track_lanes(
            s_trk,
            fit.heading_rad,
            fit.curvature_per_m,
            fit.slope,
            fit.near_m,
            fit.far_m,
            fit.trackable,
            trk,
            fit.cov,
            fit.lookahead_m,
        )
        curv["super_heading_rad"] = track.heading_rad
        curv["super_track_used"] = track.used
        curv["super_track_gated"] = track.gated
        curv["super_track_road_curvature"] = track.road_per_m
        curv["super_track_lateral_curvature"] = track.manoeuvre_per_m
        # The truth is RTK smoothed over window_m of arc length: compare like with like.
        s_rtk = curv["s_m"].to_numpy(dtype=np.float64)
        for name, values in (("road", track.road_per_m), ("lateral", track.manoeuvre_per_m)):
            curv[f"super_{name}_curvature"] = smooth_like_truth(
                s_rtk, values, config.rtk.window_m, config.rtk.ds_m
            )
        curv["super_path_curvature"] = (
            curv["super_road_curvature"] + curv["super_lateral_curvature"]
        )
        chosen = "track"
        notes.append(
            f"lane tracker: {int(track.used.sum())} of {len(curv)} frame fits used, "
            f"{int(track.gated.sum())} rejected by the innovation gate"
        )
    if chosen == "sg":
        for name in ("road", "lateral", "path"):
            curv[f"super_{name}_curvature"] = curv[f"super_{name}_sg_curvature"]


def report_sections(
    config: ReprocessConfig, facts: ReportFacts, result: DriveTables, images: Sequence[str]
) -> list[Section]:
    """Return the report's sections: the run, curvature and availability, with the plots."""
    summary, av_seqs, curv = (
        result.curvature_summary,
        result.availability_sequences,
        result.curvature,
    )
    n_frames = facts.n_frames
    lost = [f"- LOST: {s.what} ({s.n_items}): {s.detail}" for s in facts.skipped]
    overview = Section(
        "Run",
        [
            f"- frames: {n_frames}",
            f"- segmentation backend: {facts.backend_name}",
            f"- corridor network: {facts.corridor_unavailable or 'available'}",
            *[f"- {note}" for note in facts.notes],
            *lost,
        ],
    )
    overall = summary[summary["scope"] == "overall"].drop(
        columns=["scope", "category", "start", "stop"]
    )
    curvature = Section(
        "Curvature against RTK (1/m, left positive)",
        [
            "Truth: RTK path curvature at the vehicle (Savitzky-Golay over "
            f"{config.rtk.window_m} m of arc length, degraded fixes excluded). "
            "`super` is the fit's raw 2*a2 at the frame time: the curvature of a quadratic over "
            "the lines' supported range ahead, so it describes the road about half that range "
            "ahead and leaves out the vehicle's own lateral manoeuvres. `super_path` is the "
            "like-for-like estimate of the path curvature at the vehicle, `super_road` the "
            f"same without the vehicle's lateral manoeuvres; {_path_method(config.tracking)} "
            "Mobileye curvature is 2*C2 (defined at the vehicle) with its sign flipped into the "
            "left-positive lane model convention.",
            f"- frames with RTK truth: {int(curv['rtk_curvature'].notna().sum())} of {n_frames}",
        ],
        [overall],
        [i for i in images if "curvature" in i],
    )
    av_lines = [
        f"Available: corridor width in [{config.kpi.min_width_m}, {config.kpi.max_width_m}] m and "
        f"length >= speed * {config.kpi.time_gap_s} s. Sequences: {config.kpi.window_s} s "
        f"windows (or manifest segments); a sequence is available with no outage longer than "
        f"{config.kpi.max_outage_s:.3g} s (dropped frames count as outage). Columns: "
        "`n_frames` frames in the sequence, `n_available` frames available, `n_unknown` frames "
        "whose availability is unknown (no speed), `ratio` = n_available / n_frames, "
        "`available` the sequence decision (empty: decided by unknown frames), "
        "`longest_outage_s` the longest outage, `method_ran` whether the method produced output "
        "on this drive at all (False: not run, e.g. no corridor model; not a result), "
        f"`median_width_m` the median corridor width. Every method's width is measured "
        f"{config.kpi.width_at_m:g} m ahead (`kpi.width_at_m`; at the corridor's far end when "
        "it is shorter), and widths and lengths are measured from one origin, the camera's "
        "vehicle frame (the camera foot with default extrinsics): SUPER between its fitted ego "
        "lines, the corridor network from its mask projected to the ground, the Hough baseline "
        "between its two lines, Mobileye between its two lines (both quality >= 2; its own "
        "camera taken at that origin), length = its view range."
    ]
    shown = pd.DataFrame()
    if not av_seqs.empty:
        shown = av_seqs[
            [
                "method",
                "sequence",
                "category",
                "n_frames",
                "n_available",
                "n_unknown",
                "ratio",
                "available",
                "longest_outage_s",
                "median_width_m",
                "method_available",
            ]
        ].rename(columns={"method_available": "method_ran"})
    availability = Section(
        "Availability",
        av_lines,
        [shown] if len(shown) else [],
        [i for i in images if "availability" in i],
    )
    examples = Section(
        "Example frames",
        [
            "Segmentation, BEV lane pixels, offset histogram "
            "with peaks, fitted lanes (colour and style)."
        ],
        (),
        [i for i in images if "example" in i],
    )
    floor = float(summary["truth_noise_floor_per_m"].iloc[0]) if len(summary) else float("nan")
    degraded = bool(summary["truth_degraded"].iloc[0]) if len(summary) else False
    headline = Section(
        "Headline",
        [
            "One number per method: curvature RMSE against the same truth (1/m; the path methods "
            "get the same placement, smoothing and manoeuvre term) and availability "
            "(frames and sequences, see Availability). No RMSE can be read below the truth's "
            "own noise floor."
            + (" Truth degraded: not RTK (plain GNSS fixes)." if degraded else ""),
        ],
        [headline_table(summary, av_seqs, floor)],
    )
    return [headline, overview, curvature, availability, examples]


UNTRACKED_PATH = (
    "2*a2 placed at the middle of the ego lines' supported range ahead and read back at the "
    "vehicle's arc length, smoothed with the truth's filter, plus the second derivative along "
    "the path of the vehicle's lateral position in its lane."
)


def _path_method(tracking: TrackingConfig) -> str:
    """How ``super_road`` / ``super_path`` were made, for the report."""
    if not tracking.enabled:
        return f"both come from {UNTRACKED_PATH}"
    noise = (
        "the fit's own covariance" if tracking.measurement_noise == "fit" else "fixed noise levels"
    )
    return (
        "both come from the lane tracker (Kalman filter and smoother over the distance travelled "
        f"on each frame's -a1, 2*a2 and slope, with {noise} and the look-ahead in the "
        "measurement model), smoothed with the truth's filter. `super_road_sg` / "
        f"`super_path_sg` are the untracked estimates: {UNTRACKED_PATH}"
    )
