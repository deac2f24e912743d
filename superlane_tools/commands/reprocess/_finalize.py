"""After the streaming pass: a drive's record plus CAN/GNSS -> its tables; then the writer.

:func:`drive_tables` is pure (arrays and parameters in, tables and notes out);
:func:`write_outputs` writes them with plots and the report.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from superlane_tools.can import LoadedDbc
from superlane_tools.can.collect import CanFrames
from superlane_tools.commands.reprocess.config import ReprocessConfig, TrackingConfig
from superlane_tools.commands.reprocess.record import DriveFrames
from superlane_tools.commands.reprocess.signals import (
    at_frames,
    can_frame_signals,
    mobileye_at_frames,
    mobileye_table,
    rtk_truth,
)
from superlane_tools.corridor import AvailabilityParams, Segment
from superlane_tools.lanes.lookahead import align_super_curvature, smooth_like_truth
from superlane_tools.lanes.tracker import COV_INDEX, COV_KEYS, track_lanes, travelled_m
from superlane_tools.records import Skipped
from superlane_tools.reporting import Provenance, write_table
from superlane_tools.reporting import drive_tables as tables
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
    """

    can_signals: pd.DataFrame
    mobileye: pd.DataFrame
    rtk: pd.DataFrame
    curvature: pd.DataFrame
    curvature_summary: pd.DataFrame
    availability_frames: pd.DataFrame
    availability_sequences: pd.DataFrame
    notes: tuple[str, ...]

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
) -> DriveTables:
    """Turn a drive's per-frame record plus its CAN frames and GNSS fixes into its tables."""
    t_ns = frames.t_ns
    fit = frames.fit
    notes: list[str] = []
    signals = can.decode(dbcs)
    speed_s, yaw_s = can_frame_signals(signals, config.can)
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
    me = mobileye_table(signals, config.can.mobileye_right_positive)
    me_curv = mobileye_at_frames(me, t_ns)
    if len(can) and me.empty:
        notes.append("no Mobileye lane messages on CAN: no Mobileye comparison")
    rtk = rtk_truth(gnss_rows, t_ns, config.rtk)
    if rtk.fixes.empty:
        notes.append("no GNSS/RTK stream: no curvature ground truth")
    elif rtk.n_degraded or rtk.n_dropouts:
        notes.append(
            f"RTK: {rtk.n_degraded} degraded fixes flagged and excluded, "
            f"{rtk.n_dropouts} dropouts > {config.rtk.max_gap_s} s"
        )
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
    curv["super_error"] = curv["super_curvature"] - curv["rtk_curvature"]
    curv["super_path_error"] = curv["super_path_curvature"] - curv["rtk_curvature"]
    curv["mobileye_error"] = curv["mobileye_curvature"] - curv["rtk_curvature"]
    summary = tables.curvature_summary(curv, segments)
    unavailable = {"corridor_net": corridor_unavailable} if corridor_unavailable else {}
    av_frames, av_seqs, _ = tables.availability_tables(
        t_ns, frames.corridors.by_method(), unavailable, speed, params, segments
    )
    return DriveTables(signals, me, rtk.fixes, curv, summary, av_frames, av_seqs, tuple(notes))


def write_outputs(
    out: Path,
    result: DriveTables,
    provenance: Provenance,
    config: ReprocessConfig,
    examples: Sequence[ExampleFrame],
    report: ReportFacts,
) -> list[Path]:
    """Write the derived tables, the plots and the report; return the files written."""
    written = [write_table(t, out / name, provenance) for name, t in result.files().items()]
    images: list[str] = []
    if config.output.plots:
        from superlane_tools.reporting.plots import plot_all

        pngs = plot_all(result.curvature, result.availability_frames, examples, out / "plots")
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
        f"{config.kpi.max_outage_frames} frames."
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
        ]
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
    return [overview, curvature, availability, examples]


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
