"""After the streaming pass: signal tables, RTK truth, KPIs, curvature comparison, plots, report."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from superlane_tools.can import LoadedDbc
from superlane_tools.corridor import AvailabilityParams, Segment
from superlane_tools.pipeline.reprocess import outputs as tables
from superlane_tools.pipeline.reprocess.config import ReprocessConfig, TrackingConfig
from superlane_tools.pipeline.reprocess.curvature_align import (
    align_super_curvature,
    smooth_like_truth,
)
from superlane_tools.pipeline.reprocess.lane_tracker import (
    COV_KEYS,
    cov_from_columns,
    track_lanes,
    travelled_m,
)
from superlane_tools.pipeline.reprocess.signals import (
    CanFrames,
    at_frames,
    can_frame_signals,
    mobileye_at_frames,
    mobileye_table,
    rtk_truth,
)
from superlane_tools.pipeline.reprocess.stages import FrameStages
from superlane_tools.records import Skipped
from superlane_tools.reporting import Provenance, write_table
from superlane_tools.reporting.plots import ExampleFrame
from superlane_tools.reporting.report import Section, write_report


def finalize(
    *,
    out: Path,
    config: ReprocessConfig,
    provenance: Provenance,
    scalars: Mapping[str, np.ndarray],
    segments: Sequence[Segment],
    params: AvailabilityParams,
    can: CanFrames,
    dbcs: Mapping[str, LoadedDbc],
    gnss_rows: Sequence[Mapping[str, Any]],
    examples: Sequence[ExampleFrame],
    notes: list[str],
    skipped: Sequence[Skipped],
    recording: Path,
    stages: FrameStages,
) -> list[Path]:
    """Write every derived output; append missing-stream statements to ``notes``."""
    t_ns = scalars["t_ns"].astype(np.int64)
    written: list[Path] = []
    signals = can.decode(dbcs)
    written.append(write_table(signals, out / "can_signals.parquet", provenance))
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
    written.append(write_table(me, out / "mobileye.parquet", provenance))
    me_curv = mobileye_at_frames(me, t_ns)
    if len(can) and me.empty:
        notes.append("no Mobileye lane messages on CAN: no Mobileye comparison")
    rtk = rtk_truth(gnss_rows, t_ns, config.rtk)
    written.append(write_table(rtk.fixes, out / "rtk.parquet", provenance))
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
            "super_curvature": scalars["super_curv"].astype(np.float64),
            "mobileye_curvature": me_curv,
        }
    )
    aligned = align_super_curvature(
        rtk.frame_s_m,
        scalars["super_curv"].astype(np.float64),
        scalars["super_ahead"].astype(np.float64),
        scalars["super_centre"].astype(np.float64),
        scalars["super_lane_width"].astype(np.float64),
        window_m=config.rtk.window_m,
        ds_m=config.rtk.ds_m,
    )
    curv["super_lookahead_m"] = scalars["super_ahead"].astype(np.float64)
    curv["super_lateral_m"] = aligned.lateral_m
    curv["super_road_sg_curvature"] = aligned.road_per_m
    curv["super_lateral_sg_curvature"] = aligned.lateral_per_m
    curv["super_path_sg_curvature"] = aligned.path_per_m
    _add_track(curv, scalars, config, notes)
    curv["super_error"] = curv["super_curvature"] - curv["rtk_curvature"]
    curv["super_path_error"] = curv["super_path_curvature"] - curv["rtk_curvature"]
    curv["mobileye_error"] = curv["mobileye_curvature"] - curv["rtk_curvature"]
    written.append(write_table(curv, out / "curvature.parquet", provenance))
    summary = tables.curvature_summary(curv, segments)
    written.append(write_table(summary, out / "curvature_summary.parquet", provenance))
    geometry = {
        "super": (scalars["super_w"], scalars["super_l"]),
        "corridor_net": (scalars["net_w"], scalars["net_l"]),
        "hough": (scalars["hough_w"], scalars["hough_l"]),
    }
    unavailable = (
        {"corridor_net": stages.corridor_unavailable} if stages.corridor_unavailable else {}
    )
    av_frames, av_seqs, _ = tables.availability_tables(
        t_ns, geometry, unavailable, speed, params, segments
    )
    written.append(write_table(av_frames, out / "availability_frames.parquet", provenance))
    written.append(write_table(av_seqs, out / "availability_sequences.parquet", provenance))
    images: list[str] = []
    if config.output.plots:
        from superlane_tools.reporting.plots import plot_all

        pngs = plot_all(curv, av_frames, examples, out / "plots")
        written += pngs
        images = [p.relative_to(out).as_posix() for p in pngs]
    written += write_report(
        out,
        f"slt reprocess: {recording.name}",
        _sections(config, stages, notes, skipped, summary, av_seqs, curv, images, len(t_ns)),
    )
    return written


def _add_track(
    curv: pd.DataFrame,
    scalars: Mapping[str, np.ndarray],
    config: ReprocessConfig,
    notes: list[str],
) -> None:
    """Add the tracked SUPER curvature; set ``super_road`` / ``super_path`` from it (or SG)."""
    trk = config.tracking
    s_trk = travelled_m(curv["log_time_ns"].to_numpy(), curv["speed_mps"].to_numpy())
    if trk.enabled and not np.isfinite(s_trk).any():
        s_trk = curv["s_m"].to_numpy(dtype=np.float64)
        notes.append("lane tracker: no CAN speed, travelled distance from the RTK track")
    curv["super_travelled_m"] = s_trk
    # The tracker's inputs, kept so that a track can be audited (or re-run) from the table.
    inputs = {
        "super_fit_a1": "super_a1",
        "super_fit_b": "super_b",
        "super_fit_near_m": "super_near",
        "super_fit_far_m": "super_far",
        "super_fit_trackable": "super_track_ok",
        **{key: key for key in COV_KEYS},
    }
    for column, key in inputs.items():
        curv[column] = scalars[key].astype(np.float64)
    fit_cov = cov_from_columns([scalars[key].astype(np.float64) for key in COV_KEYS])
    chosen = "sg"
    if trk.enabled and np.isfinite(s_trk).sum() >= 2:
        track = track_lanes(
            s_trk,
            scalars["super_a1"].astype(np.float64),
            scalars["super_curv"].astype(np.float64),
            scalars["super_b"].astype(np.float64),
            scalars["super_near"].astype(np.float64),
            scalars["super_far"].astype(np.float64),
            scalars["super_track_ok"].astype(bool),
            trk,
            fit_cov,
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
    config: ReprocessConfig,
    stages: FrameStages,
    notes: Sequence[str],
    skipped: Sequence[Skipped],
    summary: pd.DataFrame,
    av_seqs: pd.DataFrame,
    curv: pd.DataFrame,
    images: Sequence[str],
    n_frames: int,
) -> list[Section]:
    lost = [f"- LOST: {s.what} ({s.n_items}): {s.detail}" for s in skipped]
    overview = Section(
        "Run",
        [
            f"- frames: {n_frames}",
            f"- segmentation backend: {stages.backend_name}",
            f"- corridor network: {stages.corridor_unavailable or 'available'}",
            *[f"- {note}" for note in notes],
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
