"""What a drive had and what could therefore be measured: computed once, worded elsewhere.

:class:`DriveFacts` is filled once, after the streaming pass, from the drive's streams and the
tables derived from them (``drive.finalize``); :mod:`~superlane_tools.reporting.drive_notes`
turns it into every note, the headline's inputs line and each section's "not evaluated"
statement, so no two sentences of a report can disagree about the same fact.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

from superlane_tools.reporting.availability_reasons import MethodReasons

SPEED_CAN = "CAN"
SPEED_GNSS = "GNSS"
"""Speed sources: the CAN speed signal, or the speed of the GNSS track."""
TRUTH_RTK = "RTK"
TRUTH_GNSS = "GNSS"
"""Truth sources: RTK fixes, or plain GNSS fixes only (degraded)."""
YAW_CAN = "CAN"
YAW_IMU = "IMU"
"""Yaw-rate sources."""
TRAVELLED_SPEED = "speed"
TRAVELLED_TRACK = "GNSS track"
"""Where the lane tracker's distance travelled comes from."""


class LatencyFacts(NamedTuple):
    """Mobileye's latency behind the camera frames, and whether the drive pins it.

    Attributes:
        lag_s: Lag, seconds (NaN not estimated).
        correlation: Peak normalised correlation.
        sharpness: Drop of the correlation one frame period either side of the peak, in units
            of the misfit ``1 - correlation``.
        period_s: The camera frame period the lag is judged at, seconds.
        resolved: Whether the data pins the lag to one frame period.
        reason: Why it is not estimated or not resolved ("" when resolved).
    """

    lag_s: float
    correlation: float = math.nan
    sharpness: float = math.nan
    period_s: float = math.nan
    resolved: bool = False
    reason: str = ""


class CameraFacts(NamedTuple):
    """Where the camera came from, and which of its values are assumptions, not measurements.

    Filled from the ``estimate:`` block that ``slt camera estimate`` writes into a profile.

    Attributes:
        profile: The profile file the camera was read from ("" when from the recording).
        lane_width_m: The lane width the camera height was scaled to (NaN: the height was not
            scaled to an assumed width): lane and corridor widths are then circular.
        intrinsics: How the intrinsics were obtained (the estimate's words; "" unknown).
        intrinsics_assumed: Whether the field of view was assumed, not given or measured.
        roll_deg: The estimated roll, degrees (NaN: given, not estimated, or unknown).
        roll_frames: Frames the roll was estimated from.
    """

    profile: str = ""
    lane_width_m: float = math.nan
    intrinsics: str = ""
    intrinsics_assumed: bool = False
    roll_deg: float = math.nan
    roll_frames: int = 0


@dataclass(frozen=True)
class DriveFacts:
    """The inputs of one drive and what each allowed to be measured.

    Attributes:
        n_instants: Evaluation instants: the camera frames, or the grid without a camera.
        camera: Whether the drive had camera frames (SUPER, corridor network, Hough ran).
        grid_hz: Rate of the evaluation grid without a camera, Hz (0 with a camera).
        can: Whether the drive had CAN frames.
        can_coverage: The DBC coverage line ("" without CAN).
        speed_signal: The configured CAN speed signal.
        speed: :data:`SPEED_CAN`, :data:`SPEED_GNSS` or "" (unknown).
        gnss: Whether the drive had GNSS fixes.
        n_fixes: GNSS fixes.
        gnss_plain: Whether the fixes are plain GNSS (no RTK fixed fix).
        truth: :data:`TRUTH_RTK`, :data:`TRUTH_GNSS` (plain fixes, degraded) or "" (none).
        truth_instants: Instants with a valid curvature truth.
        n_degraded: Fixes flagged degraded and excluded.
        n_dropouts: Gaps between fixes longer than ``max_gap_s``.
        n_slow: Fixes while standing or crawling (no truth there).
        min_speed_mps: Slowest speed with a truth sample, m/s.
        min_step_m: Decimation step of the fixes, m.
        max_gap_s: Longest gap between fixes that is not a dropout, s.
        noise_floor_per_m: The truth's own curvature noise floor, 1/m (NaN unknown).
        yaw: :data:`YAW_CAN`, :data:`YAW_IMU` or "" (none).
        imu_axis: IMU axis of the yaw rate.
        dynamics: Whether the yaw-rate / speed curvature reference exists.
        gyro_bias_rps: Gyro bias removed from the yaw rate, rad/s.
        gyro_bias_source: How the bias was found.
        mobileye: Whether the drive had Mobileye lane messages.
        mobileye_lane_rms: RMS difference of Mobileye's 0x737 Lane_Curvature and 2*C2, 1/m.
        latency: Mobileye's latency (None without Mobileye).
        tracker: Whether the lane tracker ran.
        travelled: Where the tracker's distance travelled came from ("" none).
        tracker_used: Frame fits the tracker used.
        tracker_gated: Frame fits the innovation gate rejected.
        corridor_unavailable: Why the corridor network did not run ("" when it ran).
        duration_s: From the first to the last evaluation instant, seconds.
        frame_gaps_s: Camera time missing between the frames read: the sum over steps longer
            than 1.5 frame periods of the step less one period, seconds (0 without a camera).
        availability: Per method that ran: frames available, unknown and why not.
        length_cap_m: The camera's measurable range that corridor lengths were capped at, m
            (inf: no cap).
        n_capped: Method -> frames whose corridor length was capped.
        camera_facts: Where the camera came from and what of it is assumed (None: unknown).
    """

    n_instants: int
    camera: bool
    grid_hz: float = 0.0
    can: bool = False
    can_coverage: str = ""
    speed_signal: str = ""
    speed: str = ""
    gnss: bool = False
    n_fixes: int = 0
    gnss_plain: bool = False
    truth: str = ""
    truth_instants: int = 0
    n_degraded: int = 0
    n_dropouts: int = 0
    n_slow: int = 0
    min_speed_mps: float = 0.0
    min_step_m: float = 0.0
    max_gap_s: float = 0.0
    noise_floor_per_m: float = math.nan
    yaw: str = ""
    imu_axis: str = ""
    dynamics: bool = False
    gyro_bias_rps: float = math.nan
    gyro_bias_source: str = ""
    mobileye: bool = False
    mobileye_lane_rms: float = math.nan
    latency: LatencyFacts | None = None
    tracker: bool = False
    travelled: str = ""
    tracker_used: int = 0
    tracker_gated: int = 0
    corridor_unavailable: str = ""
    duration_s: float = 0.0
    frame_gaps_s: float = 0.0
    availability: tuple[MethodReasons, ...] = ()
    length_cap_m: float = math.inf
    n_capped: tuple[tuple[str, int], ...] = ()
    camera_facts: CameraFacts | None = None

    @property
    def widths_circular(self) -> bool:
        """Whether widths are circular: the camera height was scaled to an assumed lane width."""
        return self.camera_facts is not None and math.isfinite(self.camera_facts.lane_width_m)

    def methods_run(self) -> tuple[str, ...]:
        """Return the availability methods that produced output on this drive."""
        image: tuple[str, ...] = ("super",) if self.camera else ()
        if self.camera and not self.corridor_unavailable:
            image += ("corridor_net",)
        if self.camera:
            image += ("hough",)
        return image + (("mobileye",) if self.mobileye else ())

    def curvature_sources_run(self) -> tuple[str, ...]:
        """Return the curvature sources that exist on this drive (``<source>_curvature``)."""
        sources: tuple[str, ...] = ()
        if self.camera:
            sources += ("super", "super_road", "super_path", "super_road_sg", "super_path_sg")
        if self.mobileye:
            sources += ("mobileye", "mobileye_path")
        if self.dynamics:
            sources += ("dynamics",)
        return sources
