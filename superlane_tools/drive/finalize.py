"""After the streaming pass: a drive's record plus CAN/GNSS -> its tables and report sections.

:func:`drive_tables` is pure (arrays and parameters in, tables and the drive's facts out); the
report's prose lives in :mod:`superlane_tools.reporting` (``drive_notes``, ``drive_sections``):
:func:`report_sections` only hands it the tables and the configuration values it quotes.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from superlane_tools.can import MAPPINGS, LoadedDbc, MobileyeMapping, line_latency, mobileye_table
from superlane_tools.can.collect import CanFrames
from superlane_tools.can.errors import CanError
from superlane_tools.corridor import (
    AvailabilityParams,
    Segment,
    TimeSegment,
    segments_at_times,
    windows,
)
from superlane_tools.drive.config import ReprocessConfig, load_manifest
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
from superlane_tools.geo.dynamics import DynamicsCurvature
from superlane_tools.lanes.lookahead import align_super_curvature, smooth_like_truth
from superlane_tools.lanes.sequence import max_plausible_slope
from superlane_tools.lanes.tracker import COV_INDEX, COV_KEYS, track_lanes, travelled_m
from superlane_tools.records import Skipped
from superlane_tools.reporting import drive_tables as tables
from superlane_tools.reporting.availability_reasons import (
    NOT_DECODED,
    NOT_PLAUSIBLE,
    method_reasons,
)
from superlane_tools.reporting.drive_facts import (
    SPEED_CAN,
    SPEED_GNSS,
    TRAVELLED_SPEED,
    TRAVELLED_TRACK,
    TRUTH_GNSS,
    TRUTH_RTK,
    YAW_CAN,
    YAW_IMU,
    CameraFacts,
    DriveFacts,
    LatencyFacts,
)
from superlane_tools.reporting.drive_notes import drive_notes
from superlane_tools.reporting.drive_sections import (
    ReportFacts,
    ReportSettings,
    SectionTables,
    drive_sections,
)
from superlane_tools.reporting.gnss_fixes import GnssFixes
from superlane_tools.reporting.report import Section


@dataclass(frozen=True)
class DerivedTables:
    """The tables derived from a drive after the streaming pass, and what the report states.

    Attributes:
        can_signals: Decoded CAN signals (long format).
        mobileye: One row per Mobileye lane update.
        rtk: One row per GNSS fix, flagged.
        curvature: One row per frame: SUPER, tracked and Mobileye curvature against RTK.
        curvature_summary: Curvature errors overall and per sequence.
        availability_frames: Availability per frame and method.
        availability_sequences: Availability per sequence and method.
        notes: What the drive had and lacked, fallbacks and estimates
            (:func:`~superlane_tools.reporting.drive_notes.drive_notes` of ``facts``).
        facts: Which inputs the drive had and what could therefore be measured.
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
    facts: DriveFacts
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
    length_cap_m: float = math.inf,
    camera_facts: CameraFacts | None = None,
) -> DerivedTables:
    """Turn a drive's per-frame record plus its CAN frames and GNSS fixes into its tables.

    The steps: the vehicle's signals and the truth at the frames, Mobileye's lanes, the
    yaw-rate / speed reference, the curvature table and its summary, then availability (the
    image methods' corridor lengths capped at ``length_cap_m``, the camera's measurable range,
    :func:`~superlane_tools.corridor.measurable_range_m`; each method's unavailable frames
    counted by reason). ``camera_facts``: where the camera came from and what of it is assumed.

    Raises:
        CanError: If a used CAN signal has no or an unknown unit, or the Mobileye mapping is
            unknown.
    """
    t_ns = frames.t_ns
    facts: dict[str, Any] = {"n_instants": len(t_ns), "camera": camera, "can": bool(len(can))}
    facts["duration_s"] = float(t_ns[-1] - t_ns[0]) / 1e9 if len(t_ns) else 0.0
    facts["frame_gaps_s"] = _frame_gaps_s(t_ns) if camera else 0.0
    facts["camera_facts"] = camera_facts
    if not camera:
        facts["grid_hz"] = frames.frame_rate_hz()
    lost: list[Skipped] = []
    vehicle = _vehicle_signals(can, dbcs, gnss, t_ns, config, facts, lost)
    me, mapping = _mobileye(vehicle.signals, config)
    facts["mobileye"] = not me.empty
    facts.update(_truth_facts(vehicle.rtk, config))
    dyn = _dynamics(vehicle, imu, t_ns, config, facts)
    curv = _curvature_table(frames, vehicle, me, dyn, config, facts)
    latency = mobileye_latency(frames.fit, me, t_ns, mapping.min_quality) if camera else None
    facts["latency"] = latency
    summary = _curvature_summary(curv, segments, vehicle.rtk, latency)
    av_frames, av_seqs, capped = _availability(
        frames,
        me,
        vehicle.speed,
        params,
        segments,
        (corridor_unavailable, camera),
        length_cap_m,
        max_plausible_slope(config.fit_params, config.tracking.max_slope_fraction),
    )
    drive = DriveFacts(**facts, corridor_unavailable=corridor_unavailable if camera else "")
    drive = replace(
        drive,
        availability=tuple(
            method_reasons(av_frames, drive.methods_run(), params.min_width_m, params.max_width_m)
        ),
        length_cap_m=length_cap_m,
        n_capped=capped,
    )
    return DerivedTables(
        vehicle.signals,
        me,
        vehicle.rtk.fixes,
        curv,
        summary,
        av_frames,
        av_seqs,
        tuple(drive_notes(drive)),
        drive,
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
    facts: dict[str, Any],
    lost: list[Skipped],
) -> _Vehicle:
    """Decode CAN (its DBC coverage), pick speed and yaw rate (their sources), build the truth."""
    signals = can.decode(dbcs)
    if len(can):
        coverage = can.coverage(dbcs)
        facts["can_coverage"] = coverage.line()
        if coverage.none_matched:
            detail = f"no CAN id matched by any DBC: 0 of {coverage.seen} ids (wrong DBC?)"
            lost.append(Skipped("CAN signals", detail, coverage.seen))
    speed_s, yaw_s = can_frame_signals(signals, config.can)
    facts["speed_signal"] = config.can.speed_signal
    facts["speed"] = SPEED_CAN if speed_s is not None else ""
    facts["yaw"] = YAW_CAN if yaw_s is not None else ""
    rtk = rtk_truth(gnss, t_ns, config.rtk, speed_s)
    if speed_s is None and (fallback := gnss_speed(rtk)) is not None:
        speed_s, facts["speed"] = fallback, SPEED_GNSS
    speed, yaw = at_frames(speed_s, t_ns), at_frames(yaw_s, t_ns)
    if not np.isfinite(speed).any():  # e.g. fixes too far apart to bridge: no speed anywhere
        facts["speed"] = ""
    return _Vehicle(signals, speed_s, yaw_s, speed, yaw, rtk)


def _mobileye(
    signals: pd.DataFrame, config: ReprocessConfig
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
    return mobileye_table(signals, mapping, config.kpi.width_at_m), mapping


def _dynamics(
    vehicle: _Vehicle,
    imu: ImuSamples | None,
    t_ns: NDArray[np.int64],
    config: ReprocessConfig,
    facts: dict[str, Any],
) -> DynamicsCurvature | None:
    """Return the yaw-rate / speed curvature reference (the IMU's yaw rate without CAN's)."""
    yaw_s = vehicle.yaw_s
    if yaw_s is None and imu is not None and len(imu):
        yaw_s = imu.yaw_series(config.rtk.imu_yaw_axis)
        facts["yaw"], facts["imu_axis"] = YAW_IMU, config.rtk.imu_yaw_axis
    dyn = dynamics_reference(yaw_s, vehicle.speed_s, t_ns, config.rtk)
    if dyn is not None and np.isfinite(dyn.curvature_per_m).any():
        facts.update(dynamics=True, gyro_bias_rps=dyn.bias.rps, gyro_bias_source=dyn.bias.source)
    return dyn


def _curvature_table(
    frames: DriveFrames,
    vehicle: _Vehicle,
    me: pd.DataFrame,
    dyn: DynamicsCurvature | None,
    config: ReprocessConfig,
    facts: dict[str, Any],
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
    facts.update(_add_track(curv, frames, config))
    facts["mobileye_lane_rms"] = _add_fair_mobileye(curv, me, t_ns, config)
    return curv


def _curvature_summary(
    curv: pd.DataFrame, segments: Sequence[Segment], rtk: RtkTruth, latency: LatencyFacts | None
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
    ran: tuple[str, bool],
    length_cap_m: float,
    max_slope: float,
) -> tuple[pd.DataFrame, pd.DataFrame, tuple[tuple[str, int], ...]]:
    """Availability of every method per frame and per sequence, and the frames capped.

    ``ran``: why the corridor network did not run ("" when it did), and whether the drive
    had a camera. The image methods' lengths are capped at ``length_cap_m``; frames whose
    image could not be decoded say so as their reason. A SUPER fit that is not plausible
    (:meth:`~superlane_tools.lanes.result.LaneFit.plausible`: road slope at ``max_slope`` or
    beyond, the view collapsed, or no finite curvature) gives no corridor: its reason is
    ``not plausible``, as it seeds no warm start and enters no tracker.
    """
    t_ns = frames.t_ns
    corridor_unavailable, camera = ran
    unavailable = {"corridor_net": corridor_unavailable} if corridor_unavailable else {}
    if me.empty:
        unavailable["mobileye"] = "no Mobileye lane messages"
    if not camera:
        unavailable.update(dict.fromkeys(IMAGE_METHODS, "no camera stream"))
    geometry: dict[str, tuple[NDArray[np.float64], NDArray[np.float64]]] = {}
    capped: list[tuple[str, int]] = []
    fit = frames.fit
    implausible = np.isfinite(frames.corridors.super_width_m) & ~(
        (np.abs(fit.slope) < max_slope) & np.isfinite(fit.curvature_per_m)
    )
    for method, (width, length) in frames.corridors.by_method().items():
        trusted = np.where(implausible, np.nan, width) if method == "super" else width
        over = np.isfinite(length) & (length > length_cap_m)
        geometry[method] = (trusted, np.where(over, length_cap_m, length))
        capped.append((method, int(over.sum())))
    geometry["mobileye"] = (
        mobileye_at_frames(me, t_ns, "corridor_width_m"),
        mobileye_at_frames(me, t_ns, "corridor_length_m"),
    )
    av_frames, av_seqs, _ = tables.availability_tables(
        t_ns, geometry, unavailable, speed, params, segments
    )
    no_corridor = av_frames["reason"] == "no corridor"
    if implausible.any():
        bad = np.isin(av_frames["frame_index"], np.flatnonzero(implausible))
        sup = av_frames["method"] == "super"
        av_frames.loc[bad & no_corridor & sup, "reason"] = NOT_PLAUSIBLE
    if camera and not frames.decoded.all():
        lost = np.isin(av_frames["frame_index"], np.flatnonzero(~frames.decoded))
        image = av_frames["method"].isin(IMAGE_METHODS) & no_corridor
        av_frames.loc[lost & image, "reason"] = NOT_DECODED
    return av_frames, av_seqs, tuple(capped)


def _frame_gaps_s(t_ns: NDArray[np.int64]) -> float:
    """Camera time missing between the frames read (steps over 1.5 periods), seconds."""
    steps = np.diff(t_ns) / 1e9
    steps = steps[steps > 0]
    if steps.size < 2:
        return 0.0
    period = float(np.median(steps))
    return float(np.sum(steps[steps > 1.5 * period] - period))


IMAGE_METHODS = ("super", "corridor_net", "hough")
"""Availability methods that need camera frames."""


def _truth_facts(rtk: RtkTruth, config: ReprocessConfig) -> dict[str, Any]:
    """The truth's facts: its source, where it exists, what was excluded, its noise floor."""
    n_truth = int(np.count_nonzero(np.isfinite(rtk.frame_curvature)))
    return {
        "gnss": not rtk.fixes.empty,
        "n_fixes": len(rtk.fixes),
        "gnss_plain": bool(rtk.degraded),
        "truth": "" if not n_truth else (TRUTH_GNSS if rtk.degraded else TRUTH_RTK),
        "truth_instants": n_truth,
        "n_degraded": rtk.n_degraded,
        "n_dropouts": rtk.n_dropouts,
        "n_slow": rtk.n_slow,
        "min_speed_mps": config.rtk.min_speed_mps,
        "min_step_m": config.rtk.min_step_m,
        "max_gap_s": config.rtk.max_gap_s,
        "noise_floor_per_m": rtk.noise_floor_per_m,
    }


def _add_fair_mobileye(
    curv: pd.DataFrame,
    me: pd.DataFrame,
    t_ns: np.ndarray,
    config: ReprocessConfig,
) -> float:
    """Give Mobileye SUPER's treatment: same smoothing and manoeuvre term, beside the raw value.

    Mobileye's ``2*C2`` describes the road at the vehicle (placement 0 m ahead); its own
    ``C0`` of both lines gives the lateral position in the lane, as SUPER's fit does. Returns
    the RMS difference of Mobileye's 0x737 ``Lane_Curvature`` and ``2*C2``, 1/m (NaN: none).
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
            return float(np.sqrt(np.mean((lane[both] - raw[both]) ** 2)))
    return float("nan")


def mobileye_latency(
    fit: FitSeries, me: pd.DataFrame, t_ns: NDArray[np.int64], min_quality: int
) -> LatencyFacts | None:
    """Estimate Mobileye's latency behind the camera frames (None without Mobileye lines).

    The signal is the lateral offset of Mobileye's two ego lines at the vehicle (``C0``, updates
    of quality >= ``min_quality``, at their own CAN log times); the reference is the same two
    offsets measured by the SUPER fit on each camera frame, which has no delay by construction.
    The offsets are placement-free: Mobileye's curvature against the RTK path curvature mixes the
    latency with where its ``C2`` describes the road (its cubic is fitted over tens of metres
    ahead), which on simulated drives moved the estimate from +0.1 s to about -0.1 s. Whether
    the drive pins the lag to one frame period is :func:`~superlane_tools.can.line_latency`'s
    rule (docs/reprocess.md).
    """
    if me.empty or "left_a0_m" not in me or "right_a0_m" not in me:
        return None
    if not (np.isfinite(fit.left_m).any() and np.isfinite(fit.right_m).any()):
        return LatencyFacts(
            float("nan"),
            reason="needs the camera frames' own lane-line offsets as the time reference; "
            "curvature against the RTK truth confounds latency with where Mobileye's C2 "
            "measures the road",
        )
    steps = np.diff(t_ns)
    steps = steps[steps > 0]  # frames may share a log time (batched bridges)
    if steps.size == 0:
        return LatencyFacts(float("nan"), reason="frame times do not advance")
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
    lag = line_latency(
        (t_ns - t0) / 1e9, np.stack([fit.left_m, fit.right_m], axis=1), me_t, offsets, period
    )
    return LatencyFacts(
        lag.lag_s, lag.correlation, lag.sharpness, period, lag.resolved, lag.unresolved
    )


def _add_track(curv: pd.DataFrame, frames: DriveFrames, config: ReprocessConfig) -> dict[str, Any]:
    """Add the tracked SUPER curvature; set ``super_road`` / ``super_path`` from it (or SG).

    Returns the tracker's facts: whether it ran, where its distance travelled came from, how
    many frame fits it used and rejected.
    """
    trk = config.tracking
    fit = frames.fit
    s_trk = travelled_m(curv["log_time_ns"].to_numpy(), curv["speed_mps"].to_numpy())
    facts: dict[str, Any] = {"travelled": TRAVELLED_SPEED if np.isfinite(s_trk).any() else ""}
    if trk.enabled and not np.isfinite(s_trk).any():
        s_trk = curv["s_m"].to_numpy(dtype=np.float64)
        facts["travelled"] = TRAVELLED_TRACK if np.isfinite(s_trk).any() else ""
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
        facts.update(
            tracker=True,
            tracker_used=int(track.used.sum()),
            tracker_gated=int(track.gated.sum()),
        )
    if chosen == "sg":
        for name in ("road", "lateral", "path"):
            curv[f"super_{name}_curvature"] = curv[f"super_{name}_sg_curvature"]
    return facts


def report_sections(
    config: ReprocessConfig, facts: ReportFacts, result: DerivedTables, images: Sequence[str]
) -> list[Section]:
    """Return the report's sections (:func:`~superlane_tools.reporting.drive_sections`)."""
    tables_in = SectionTables(
        result.curvature, result.curvature_summary, result.availability_sequences
    )
    return drive_sections(report_settings(config), facts, result.facts, tables_in, images)


def report_settings(config: ReprocessConfig) -> ReportSettings:
    """Return the configuration values the report quotes."""
    kpi, trk = config.kpi, config.tracking
    return ReportSettings(
        truth_window_m=config.rtk.window_m,
        tracking=trk.enabled,
        fit_noise=trk.measurement_noise == "fit",
        min_width_m=kpi.min_width_m,
        max_width_m=kpi.max_width_m,
        time_gap_s=kpi.time_gap_s,
        window_s=kpi.window_s,
        max_outage_s=kpi.max_outage_s,
        width_at_m=kpi.width_at_m,
    )
