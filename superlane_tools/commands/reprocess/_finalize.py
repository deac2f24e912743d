"""After the streaming pass: a drive's record plus CAN/GNSS -> its tables; then the writer.

:func:`drive_tables` is pure (arrays and parameters in, tables and notes out);
:func:`write_outputs` writes them with plots and the report.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from superlane_tools.can import MAPPINGS, LoadedDbc, latency_by_xcorr, mobileye_table
from superlane_tools.can.collect import CanFrames
from superlane_tools.can.errors import CanError
from superlane_tools.commands.reprocess.config import ReprocessConfig, TrackingConfig
from superlane_tools.commands.reprocess.record import DriveFrames
from superlane_tools.commands.reprocess.signals import (
    ImuSamples,
    at_frames,
    can_frame_signals,
    dynamics_reference,
    gnss_speed,
    mobileye_at_frames,
    rtk_truth,
)
from superlane_tools.corridor import AvailabilityParams, Segment
from superlane_tools.geo import DEGRADED_NOTE
from superlane_tools.lanes.lookahead import align_super_curvature, smooth_like_truth
from superlane_tools.lanes.tracker import COV_INDEX, COV_KEYS, track_lanes, travelled_m
from superlane_tools.records import Skipped
from superlane_tools.reporting import Provenance, write_table
from superlane_tools.reporting import drive_tables as tables
from superlane_tools.reporting.headline import headline_table
from superlane_tools.reporting.plots import ExampleFrame
from superlane_tools.reporting.report import Section, write_report


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

    def files(self) -> dict[str, pd.DataFrame]:
        """Return output file name -> table."""
        return {
            "can_signals.parquet": self.can_signals,
            "mobileye.parquet": self.mobileye,
            "rtk.parquet": self.rtk,
            "curvature.parquet": self.curvature,
            "curvature_summary.parquet": self.curvature_summary,
            "availability_frames.parquet": self.availability_frames,
            "availability_sequences.parquet": self.availability_sequences,
        }


def drive_tables(
    frames: DriveFrames,
    can: CanFrames,
    dbcs: Mapping[str, LoadedDbc],
    gnss_rows: Sequence[Mapping[str, Any]],
    config: ReprocessConfig,
    segments: Sequence[Segment],
    params: AvailabilityParams,
    corridor_unavailable: str,
    imu: ImuSamples | None = None,
    camera: bool = True,
) -> DriveTables:
    """Turn a drive's per-frame record plus its CAN frames and GNSS fixes into its tables.

    Raises:
        CanError: If a used CAN signal has no or an unknown unit, or the Mobileye mapping is
            unknown.
    """
    t_ns = frames.t_ns
    fit = frames.fit
    notes: list[str] = []
    lost: list[Skipped] = []
    signals = can.decode(dbcs)
    if len(can):
        coverage = can.coverage(dbcs)
        notes.append(coverage.line())
        if coverage.none_matched:
            detail = f"no CAN id matched by any DBC: 0 of {coverage.seen} ids (wrong DBC?)"
            lost.append(Skipped("CAN signals", detail, coverage.seen))
    speed_s, yaw_s = can_frame_signals(signals, config.can)
    rtk = rtk_truth(gnss_rows, t_ns, config.rtk, speed_s)
    if speed_s is None and (fallback := gnss_speed(rtk)) is not None:
        speed_s = fallback
        notes.append("speed: no CAN speed, estimated from the GNSS fixes")
    speed = at_frames(speed_s, t_ns)
    yaw = at_frames(yaw_s, t_ns)
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
    if config.can.mobileye_mapping not in MAPPINGS:
        raise CanError(
            f"unknown can.mobileye_mapping {config.can.mobileye_mapping!r}; "
            f"shipped: {', '.join(MAPPINGS)}"
        )
    mapping = replace(
        MAPPINGS[config.can.mobileye_mapping], right_positive=config.can.mobileye_right_positive
    )
    me = mobileye_table(signals, mapping)
    me_curv = mobileye_at_frames(me, t_ns)
    if len(can) and me.empty:
        notes.append("no Mobileye lane messages on CAN: no Mobileye comparison")
    notes += _truth_notes(rtk, config)
    if yaw_s is None and imu is not None and len(imu):
        yaw_s = imu.yaw_series(config.rtk.imu_yaw_axis)
        notes.append(f"yaw rate: IMU gyro about {config.rtk.imu_yaw_axis}")
    dyn = dynamics_reference(yaw_s, speed_s, t_ns, config.rtk)
    if dyn is None:
        notes.append("no yaw-rate / speed reference: no dynamics curvature cross-check")
    else:
        notes.append(f"yaw-rate reference: gyro bias {dyn.bias.rps:.2e} rad/s ({dyn.bias.source})")
    curv = pd.DataFrame(
        {
            "frame_index": np.arange(len(t_ns), dtype=np.int32),
            "log_time_ns": t_ns,
            "t_s": (t_ns - (t_ns[0] if len(t_ns) else 0)) / 1e9,
            "s_m": rtk.frame_s_m,
            "speed_mps": speed,
            "yaw_rate_rps": yaw,
            "rtk_curvature": rtk.frame_curvature,
            "rtk_valid": rtk.frame_valid,
            "super_curvature": fit.curvature_per_m,
            "mobileye_curvature": me_curv,
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
    curv["super_error"] = curv["super_curvature"] - curv["rtk_curvature"]
    curv["super_path_error"] = curv["super_path_curvature"] - curv["rtk_curvature"]
    curv["mobileye_error"] = curv["mobileye_curvature"] - curv["rtk_curvature"]
    summary = tables.curvature_summary(curv, segments)
    summary["truth_noise_floor_per_m"] = rtk.noise_floor_per_m
    summary["truth_degraded"] = rtk.degraded
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
    return DriveTables(
        signals, me, rtk.fixes, curv, summary, av_frames, av_seqs, tuple(notes), tuple(lost)
    )


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
        truth = curv["rtk_curvature"].to_numpy(dtype=np.float64)
        t_s = (t_ns - t_ns[0]) / 1e9 if len(t_ns) else np.zeros(0)
        lag = latency_by_xcorr(t_s, truth, raw)
        notes.append(
            f"Mobileye latency by cross-correlation with the truth: {lag.lag_s:.2f} s "
            f"(correlation {lag.correlation:.2f})"
        )
        lane = mobileye_at_frames(me, t_ns, "lane_curvature")
        both = np.isfinite(lane) & np.isfinite(raw)
        if both.any():
            rms = float(np.sqrt(np.mean((lane[both] - raw[both]) ** 2)))
            notes.append(f"Mobileye 0x737 Lane_Curvature vs 2*C2: RMS difference {rms:.2e} 1/m")


def write_outputs(
    out: Path,
    result: DriveTables,
    provenance: Provenance,
    config: ReprocessConfig,
    examples: Sequence[ExampleFrame],
    report: ReportFacts,
    rendered: Sequence[Path] = (),
) -> list[Path]:
    """Write the derived tables, the plots and the report; return the files written.

    ``rendered``: example plots already written (during the pass), listed after the plots
    drawn here, as :func:`~superlane_tools.reporting.plots.plot_all` orders its own examples.
    """
    written = [write_table(t, out / name, provenance) for name, t in result.files().items()]
    images: list[str] = []
    if config.output.plots:
        from superlane_tools.reporting.plots import plot_all

        pngs = plot_all(result.curvature, result.availability_frames, examples, out / "plots")
        pngs += rendered
        written += pngs
        images = [p.relative_to(out).as_posix() for p in pngs]
    written += write_report(
        out / "report.md",
        f"slt reprocess: {report.recording.name}",
        _sections(config, report, result, images),
    )
    return written


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


def _sections(
    config: ReprocessConfig, facts: ReportFacts, result: DriveTables, images: Sequence[str]
) -> list[Section]:
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
        "on this drive at all (False: not run, e.g. no corridor model; not a result). Mobileye's "
        "corridor is its two lines (both quality >= 2), width 10 m ahead, length = view range."
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
