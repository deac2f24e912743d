"""Every sentence a run states about its inputs, worded from one :class:`DriveFacts`.

The notes, the headline's inputs line and each section's "not evaluated" lines all come from the
same facts through the same reason phrases (:func:`why_no_speed`, :func:`why_no_truth`,
:func:`why_no_mobileye`), so one fact is said one way, once.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from pathlib import Path

from superlane_tools.geo import DEGRADED_NOTE
from superlane_tools.records import Skipped
from superlane_tools.reporting.drive_facts import (
    SPEED_GNSS,
    TRAVELLED_TRACK,
    TRUTH_GNSS,
    YAW_IMU,
    DriveFacts,
    LatencyFacts,
)

NO_CAMERA = "no camera stream"
NO_CAN = "no CAN stream"
NO_GNSS = "no GNSS stream"
IMAGE_METHODS_TEXT = "SUPER, the corridor network and Hough"


def _fmt(value: float) -> str:
    return "unknown" if not math.isfinite(value) else f"{value:.2e}"


def why_no_speed(facts: DriveFacts) -> str:
    """Why the speed is unknown ("" when it is known)."""
    if facts.speed:
        return ""
    can = NO_CAN if not facts.can else f"no CAN speed signal {facts.speed_signal!r}"
    gnss = (
        NO_GNSS
        if not facts.gnss
        else "GNSS fixes too sparse for a speed at the evaluation instants"
    )
    return f"{can}, {gnss}"


def why_no_truth(facts: DriveFacts) -> str:
    """Why there is no curvature truth at any instant ("" when there is)."""
    if facts.truth_instants:
        return ""
    if not facts.gnss:
        return NO_GNSS
    if facts.n_slow >= facts.n_fixes:
        return (
            f"all {facts.n_fixes} GNSS fixes while standing or crawling "
            f"(below {facts.min_speed_mps:g} m/s)"
        )
    return f"none of the {facts.n_fixes} GNSS fixes gives a truth at an evaluation instant"


def why_no_mobileye(facts: DriveFacts) -> str:
    """Why Mobileye is not evaluated ("" when it is)."""
    if facts.mobileye:
        return ""
    return NO_CAN if not facts.can else "no Mobileye lane messages on CAN"


def why_no_dynamics(facts: DriveFacts) -> str:
    """Why the yaw-rate / speed reference is missing ("" when it exists)."""
    if facts.dynamics:
        return ""
    missing = []
    if not facts.yaw:
        missing.append("no yaw rate: no CAN yaw-rate signal, no IMU")
    if not facts.speed:
        missing.append("no speed")
    return "; ".join(missing) or "too few yaw-rate / speed samples"


UNLIKE_TRAINING_DATA = (
    "this camera looks unlike the training data; check the camera profile with "
    "`slt camera estimate`"
)


def unlike_training_data(reason: str) -> str:
    """The warning when no segmentation backend gave plausible lanes (``reason``: why)."""
    return (
        f"Lanes not plausible: {UNLIKE_TRAINING_DATA} ({reason}). The lane, curvature and "
        "availability numbers below come from implausible lanes: do not read them as results."
    )


def inputs_line(facts: DriveFacts) -> str:
    """The headline's first line: which inputs the drive had, which numbers therefore exist."""
    had = [f"camera ({facts.n_instants} frames)" if facts.camera else NO_CAMERA]
    had.append("CAN" if facts.can else "no CAN")
    if facts.gnss:
        had.append("GNSS (plain, not RTK)" if facts.gnss_plain else "GNSS (RTK)")
    else:
        had.append("no GNSS")
    if facts.yaw == YAW_IMU:
        had.append("IMU")
    exists, missing = [], []
    if facts.camera and facts.widths_circular:
        exists.append(
            "corridor lengths of "
            + ", ".join(_camera_methods(facts))
            + " (scaled by the assumed lane width)"
        )
        missing.append("corridor widths: circular, the camera height was scaled to them")
    elif facts.camera:
        exists.append("corridor widths and lengths of " + ", ".join(_camera_methods(facts)))
    if not facts.methods_run():
        pass  # no method to judge: the missing camera / Mobileye below say why
    elif facts.speed:
        exists.append(f"availability (speed from {facts.speed})")
    else:
        missing.append(f"availability: unknown on every frame, no speed ({why_no_speed(facts)})")
    if facts.truth_instants:
        exists.append(f"curvature errors against the truth at {facts.truth_instants} instants")
    else:
        missing.append(f"curvature errors: no truth ({why_no_truth(facts)})")
    if facts.mobileye:
        exists.append("the Mobileye comparison")
    else:
        missing.append(f"Mobileye: {why_no_mobileye(facts)}")
    if not facts.camera:
        missing.append(f"{IMAGE_METHODS_TEXT}: {NO_CAMERA}")
    line = f"**Inputs:** {', '.join(had)}. **Measured:** {'; '.join(exists) or 'nothing'}."
    if missing:
        line += f" **Not measured:** {'; '.join(missing)}."
    return line


def _camera_methods(facts: DriveFacts) -> list[str]:
    names = {"super": "SUPER", "corridor_net": "the corridor network", "hough": "Hough"}
    return [names[m] for m in facts.methods_run() if m in names]


def drive_notes(facts: DriveFacts) -> list[str]:
    """Return the run's notes on its inputs, fallbacks and estimates, in a fixed order."""
    notes = [_camera_note(facts), *assumption_notes(facts), _can_note(facts), _speed_note(facts)]
    notes += _truth_notes(facts)
    notes.append(_dynamics_note(facts))
    notes += _mobileye_notes(facts)
    notes.append(_tracker_note(facts))
    return [n for n in notes if n]


def _camera_note(facts: DriveFacts) -> str:
    if facts.camera:
        return ""
    return (
        f"{NO_CAMERA}: {IMAGE_METHODS_TEXT} not computed; the signals are evaluated on a "
        f"{facts.grid_hz:g} Hz grid of {facts.n_instants} instants"
    )


def _can_note(facts: DriveFacts) -> str:
    if not facts.can:
        return f"{NO_CAN}: no CAN speed, yaw rate or Mobileye lane messages"
    return facts.can_coverage


def _speed_note(facts: DriveFacts) -> str:
    if not facts.speed:
        effect = ": availability by corridor length unknown on every frame"
        return f"speed unknown ({why_no_speed(facts)})" + (effect if facts.methods_run() else "")
    if facts.speed == SPEED_GNSS:
        can = NO_CAN if not facts.can else f"no CAN speed signal {facts.speed_signal!r}"
        return f"speed: estimated from the GNSS fixes ({can})"
    return f"speed: CAN signal {facts.speed_signal!r}"


def _truth_notes(facts: DriveFacts) -> list[str]:
    if not facts.truth_instants:
        return [f"no curvature ground truth: {why_no_truth(facts)}"]
    notes = []
    if facts.truth == TRUTH_GNSS:
        notes.append(f"{DEGRADED_NOTE}: plain GNSS fixes only (no RTK fixed fix)")
    if facts.n_degraded or facts.n_dropouts:
        notes.append(
            f"RTK: {facts.n_degraded} degraded fixes flagged and excluded, "
            f"{facts.n_dropouts} dropouts > {facts.max_gap_s} s"
        )
    notes.append(
        f"truth: {facts.truth_instants} of {facts.n_instants} instants; no sample below "
        f"{facts.min_speed_mps} m/s ({facts.n_slow} fixes while standing or crawling); fixes "
        f"decimated to >= {facts.min_step_m} m steps; noise floor "
        f"{_fmt(facts.noise_floor_per_m)} 1/m"
    )
    return notes


def _dynamics_note(facts: DriveFacts) -> str:
    if not facts.dynamics:
        return f"no yaw-rate / speed curvature reference: {why_no_dynamics(facts)}"
    source = f"IMU gyro about {facts.imu_axis}" if facts.yaw == YAW_IMU else "CAN yaw rate"
    return (
        f"yaw-rate / speed reference: {source}, speed from {facts.speed}; gyro bias "
        f"{facts.gyro_bias_rps:.2e} rad/s ({facts.gyro_bias_source})"
    )


def _mobileye_notes(facts: DriveFacts) -> list[str]:
    if not facts.mobileye:
        return [] if not facts.can else [f"{why_no_mobileye(facts)}: no Mobileye comparison"]
    notes = []
    if math.isfinite(facts.mobileye_lane_rms):
        notes.append(
            "Mobileye 0x737 Lane_Curvature vs 2*C2: RMS difference "
            f"{facts.mobileye_lane_rms:.2e} 1/m"
        )
    if facts.latency is not None:
        notes.append(latency_note(facts.latency))
    return notes


def latency_note(lat: LatencyFacts) -> str:
    """Mobileye's latency in one line: the lag only when resolved, else why not."""
    if not math.isfinite(lat.lag_s):
        return f"Mobileye latency: not estimated ({lat.reason})"
    head = (
        "Mobileye latency behind the camera frames, by cross-correlation of its ego lines' "
        f"offsets (C0) with SUPER's: {lat.lag_s:+.3f} s (correlation {lat.correlation:.2f}, "
        f"sharpness {lat.sharpness:.2f})"
    )
    if lat.resolved:
        return f"{head}; resolved to one frame period ({lat.period_s:.3f} s)"
    return f"{head}; NOT resolved to one frame period ({lat.period_s:.3f} s): {lat.reason}"


def _tracker_note(facts: DriveFacts) -> str:
    if not facts.camera:
        return ""
    if not facts.tracker:
        if not facts.travelled:
            return (
                "lane tracker: not run (no distance travelled: no speed, no GNSS fixes); "
                "curvature from the untracked fit"
            )
        return ""
    source = "the GNSS track" if facts.travelled == TRAVELLED_TRACK else f"the {facts.speed} speed"
    return (
        f"lane tracker: {facts.tracker_used} of {facts.n_instants} frame fits used, "
        f"{facts.tracker_gated} rejected by the innovation gate; distance travelled from {source}"
    )


def availability_gaps(facts: DriveFacts) -> list[str]:
    """What the availability section could not evaluate, and why (one paragraph each)."""
    lines = []
    if not facts.speed and facts.methods_run():
        lines.append(
            f"NOT EVALUATED: whether the corridor is long enough (length >= speed * gap): no "
            f"speed ({why_no_speed(facts)}). Every frame with a plausible width is `unknown`, "
            "not unavailable; the widths below are measured."
        )
    if not facts.camera:
        lines.append(f"NOT EVALUATED: {IMAGE_METHODS_TEXT} ({NO_CAMERA}).")
    elif facts.corridor_unavailable:
        lines.append(f"NOT EVALUATED: the corridor network ({facts.corridor_unavailable}).")
    if not facts.mobileye:
        lines.append(f"NOT EVALUATED: Mobileye ({why_no_mobileye(facts)}).")
    return lines


def curvature_gaps(facts: DriveFacts) -> list[str]:
    """What the curvature section could not evaluate, and why (one paragraph each)."""
    lines = []
    if not facts.truth_instants:
        lines.append(
            f"NOT EVALUATED: curvature errors, no ground truth ({why_no_truth(facts)}); "
            "the estimates are plotted without a reference."
        )
    if not facts.camera:
        lines.append(f"NOT EVALUATED: SUPER curvature ({NO_CAMERA}).")
    if not facts.mobileye:
        lines.append(f"NOT EVALUATED: Mobileye curvature ({why_no_mobileye(facts)}).")
    if not facts.dynamics:
        lines.append(f"NOT EVALUATED: yaw-rate / speed reference: {why_no_dynamics(facts)}.")
    return lines


def timing_line(timings: Mapping[str, float]) -> str:
    """The stage times of a run in one line ("" when there is nothing besides the total).

    Per-stage times (``<stage>`` wall, ``cpu_<stage>`` thread CPU) are sums over the frames
    processed by the worker threads, so together they can exceed the pass's wall time; the
    line says so. ``pass_wall`` / ``post`` / ``total`` are wall times, ``cpu_pass`` /
    ``cpu_post`` / ``cpu_total`` the process's CPU time.
    """
    run_keys = ("pass_wall", "post", "total", "cpu_pass", "cpu_post", "cpu_total")
    stage = {k: v for k, v in timings.items() if k not in run_keys and not k.startswith("cpu_")}
    stage_cpu = {k[4:]: v for k, v in timings.items() if k not in run_keys and k[4:] in stage}
    parts = []
    wall = [f"{k[:4]} {timings[k]:.1f} s" for k in ("pass_wall", "post") if k in timings]
    if wall:
        parts.append("wall: " + ", ".join(wall))
    cpu = [f"{k[4:]} {timings[k]:.1f} s" for k in run_keys[3:] if k in timings]
    if cpu:
        parts.append("process CPU: " + ", ".join(cpu))
    if stage:
        parts.append(
            "per stage, summed over the worker threads (may exceed the wall time): "
            + ", ".join(f"{k} {v:.1f} s" for k, v in stage.items())
        )
    if stage_cpu:
        parts.append(
            "per stage thread CPU: " + ", ".join(f"{k} {v:.1f} s" for k, v in stage_cpu.items())
        )
    return "; ".join(parts)


CAMERA_DOC = "docs/camera.md"


def assumption_notes(facts: DriveFacts) -> list[str]:
    """Every value of the camera that is an assumption, not a measurement, with its caveat."""
    cam = facts.camera_facts
    if cam is None:
        return []
    where = f" ({cam.profile})" if cam.profile else ""
    notes = []
    if facts.widths_circular:
        notes.append(
            f"ASSUMED, not measured: lane width {cam.lane_width_m:g} m. The camera height"
            f"{where} was scaled by `slt camera estimate` until the lane fit measured this "
            "width, so lane and corridor widths are circular by construction and are not shown "
            "as results; every distance (corridor lengths, reach) scales with the same "
            f"assumption ({CAMERA_DOC})."
        )
    if cam.intrinsics_assumed:
        notes.append(
            f"ASSUMED, not measured: {cam.intrinsics}. With an assumed field of view the pitch "
            f"missed by about 0.4 degrees on simulated drives ({CAMERA_DOC}); pass "
            "`--intrinsics`, `--focal-px` or `--hfov` to `slt camera estimate` when known."
        )
    if math.isfinite(cam.roll_deg):
        notes.append(
            f"ESTIMATED under an assumption: roll {cam.roll_deg:.2f} degrees from "
            f"{cam.roll_frames} frames, assuming the camera rides at the lane centre on "
            "average; over a short drive the lateral wander in the lane reads as up to 3 "
            f"degrees of roll ({CAMERA_DOC}); pass `--roll-deg` when the roll is known."
        )
    return notes


def capped_note(facts: DriveFacts) -> str:
    """Which corridor lengths were capped at the camera's measurable range ("" none)."""
    capped = [(m, n) for m, n in facts.n_capped if n]
    if not capped or not math.isfinite(facts.length_cap_m):
        return ""
    names = {"super": "SUPER", "corridor_net": "corridor network", "hough": "Hough"}
    counts = ", ".join(f"{names.get(m, m)} {n} of {facts.n_instants}" for m, n in capped)
    return (
        f"Corridor lengths capped at the camera's measurable range, {facts.length_cap_m:.0f} m "
        "(beyond it one image row spans more than 10 % of the distance, so a length there is "
        f"not measured): {counts} frames."
    )


def lost_lines(skipped: Sequence[Skipped], input_bytes: int, facts: DriveFacts) -> list[str]:
    """What input was lost, in seconds and messages where they can be told (one line each).

    With a loss, the camera time missing between the frames read (a lost chunk inside the
    drive) is measured from the frame times and said on a line of its own.
    """
    lines = [_lost(s, input_bytes, facts) for s in skipped]
    if lines and facts.camera and facts.frame_gaps_s > 0:
        lines.append(
            f"{facts.frame_gaps_s:.1f} s of camera frames missing between the frames read "
            "(steps longer than 1.5 frame periods)"
        )
    return lines


_BYTE = re.compile(r"\bbyte (\d+)")


def _lost(s: Skipped, input_bytes: int, facts: DriveFacts) -> str:
    count = f"{s.n_items} messages" if s.n_items else "messages lost: unknown"
    if s.what != "truncated file":
        return f"{s.what} ({count}): {s.detail}"
    at = _BYTE.search(s.detail)
    read = int(at.group(1)) if at else 0
    if not (read and input_bytes > read and facts.duration_s > 0):
        return (
            f"truncated file: {s.detail}; how much was lost is unknown (the summary that "
            "would say is gone)"
        )
    unread = input_bytes - read
    seconds = facts.duration_s * unread / read
    frames = round(facts.n_instants * unread / read)
    kind = "camera frames" if facts.camera else "evaluation instants"
    return (
        f"truncated file: read up to byte {read:,} of {input_bytes:,} "
        f"({100 * unread / input_bytes:.0f} % of the file unreadable): at least about "
        f"{seconds:.1f} s and {frames} {kind} lost (estimated from the unreadable bytes at the "
        "drive's data rate; anything recorded after the cut is not in the file and not counted)"
    )


def recover_hint(recording: Path, skipped: Sequence[Skipped]) -> str:
    """The command that writes a valid copy of a damaged recording ("" when nothing was lost)."""
    damaged = {"truncated file", "corrupt chunk", "corrupt record", "damaged summary"}
    if not any(s.what in damaged for s in skipped):
        return ""
    fixed = f"{recording.stem}.recovered{recording.suffix}"
    return f"`slt recover {recording.name} -o {fixed}` writes a valid copy of what is readable."
