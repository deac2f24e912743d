"""``slt camera estimate``'s entry: estimate the mounting, write the profile with its caveats."""

from __future__ import annotations

import math
from collections.abc import Callable
from contextlib import nullcontext
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from superlane_tools.commands.options import OutputGuard

if TYPE_CHECKING:
    from superlane_tools.commands.camera_estimate.estimate import CameraEstimate

ROLL_RELIABLE_S = 60.0
"""Drive length, seconds, below which an estimated roll is flagged: docs/camera.md measures
lane wander over short drives as up to 3 degrees of roll, and the roll within 0.75 degrees on a
60 s drive."""


def profile_target(recording: Path, out: Path | None) -> Path | None:
    """Return the profile file to write: ``out``, None for ``-`` (print), else the sidecar.

    The default is ``<recording stem>.camera.yaml`` beside the recording, the profile
    ``--camera auto`` reads.
    """
    from superlane_tools.recording.calibration import camera_sidecar

    return None if str(out) == "-" else out if out is not None else camera_sidecar(recording)


@dataclass(frozen=True)
class EstimateParams:
    """What ``slt camera estimate`` was asked (see its options).

    ``out`` is ``-o`` as typed (None: the default sidecar, ``-``: print);
    ``output_policy(target)`` is the cli's policy for the profile file, entered once to refuse
    an existing one before any work and again around the writing.
    """

    recording: Path
    out: Path | None = None
    lane_width_m: float = 3.7
    intrinsics: str | None = None
    focal_px: float | None = None
    hfov_deg: float | None = None
    frames: int = 60
    roll_deg: float | None = None
    topic: str | None = None
    name: str = "estimated"
    command: str = ""
    output_policy: Callable[[Path | None], OutputGuard] = field(
        default=lambda _target: nullcontext()
    )


@dataclass(frozen=True)
class EstimateOutput:
    """The estimate, what it assumed (one sentence each), the profile text and where it went."""

    result: CameraEstimate
    caveats: list[str]
    text: str
    written: Path | None


def run(params: EstimateParams) -> EstimateOutput:
    """Estimate the mounting and write the profile (or return it to print).

    Raises:
        OutputError: If the profile cannot be written (the default path names ``-o``).
    """
    import yaml

    p = params
    target = profile_target(p.recording, p.out)
    with p.output_policy(target):  # refuse an existing profile before the imports and any work
        pass
    from superlane_tools.camera import camera_to_yaml, load_camera
    from superlane_tools.commands.camera_estimate.estimate import estimate_camera

    known = load_camera(p.intrinsics).intrinsics if p.intrinsics is not None else None
    result = estimate_camera(
        p.recording,
        intrinsics=known,
        focal_px=p.focal_px,
        hfov_deg=p.hfov_deg,
        lane_width_m=p.lane_width_m,
        max_frames=p.frames,
        topic=p.topic,
        name=p.name,
        roll_rad=None if p.roll_deg is None else math.radians(p.roll_deg),
    )
    est = result.estimate
    caveats = _caveats(result, p.lane_width_m, p.roll_deg is None)
    comment = (
        f"Extrinsics estimated from {est.frames_used} of {est.frames_seen} frames of "
        f"{p.recording.name}.\nIntrinsics: {result.intrinsics_source}.\n"
        + "".join(f"{line}\n" for line in caveats)
        + f"Written by: {p.command}"
    )
    blocks = {**_calibration_block(p.intrinsics)}
    blocks["estimate"] = {
        **est.summary(),
        "intrinsics": result.intrinsics_source,
        "span_s": round(result.span_s, 2),
        "assumptions": caveats,
    }
    text = camera_to_yaml(result.camera, comment=comment) + yaml.safe_dump(blocks, sort_keys=False)
    _write(text, target, p.out is None, p.output_policy(target))
    return EstimateOutput(result, caveats, text, target)


def _calibration_block(intrinsics: str | None) -> dict[str, object]:
    """Return the chessboard report of an intrinsics YAML, kept in the new profile."""
    from superlane_tools.config_files import load_document

    if intrinsics is None or not Path(intrinsics).is_file():
        return {}
    source = load_document(intrinsics, "intrinsics file", ".yaml")
    if isinstance(source, dict) and "calibration" in source:
        return {"calibration": source["calibration"]}
    return {}


def _write(text: str, target: Path | None, default: bool, guard: OutputGuard) -> None:
    """Write the estimated profile; a default path in a read-only folder names ``-o``."""
    from superlane_tools.reporting import OutputError, write_text_atomic

    if target is None:
        return
    try:
        with guard:
            write_text_atomic(target, text)
    except OutputError as err:
        if not default:
            raise
        raise OutputError(
            f"{err} (the recording's folder; pass -o PATH, then --camera PATH)"
        ) from err


def _caveats(result: CameraEstimate, lane_width_m: float, roll_estimated: bool) -> list[str]:
    """Return what the estimate assumed rather than measured, one sentence each."""
    est = result.estimate
    k = result.camera.intrinsics
    lines = [
        f"ASSUMED lane width: the height ({est.extrinsics.height_m:.3f} m) is scaled so that the "
        f"lane fit measures the assumed {lane_width_m:g} m lanes; lane widths measured with "
        "this profile are that assumption, not a measurement"
    ]
    if "ASSUMED" in result.intrinsics_source:
        hfov = math.degrees(2.0 * math.atan(k.width / (2.0 * k.fx)))
        lines.append(
            f"ASSUMED field of view: {hfov:.0f} deg horizontal (no --intrinsics, --focal-px or "
            "--hfov, and the focal length could not be measured); pitch, height and every "
            "distance depend on it: calibrate with `slt camera calibrate`"
        )
    if roll_estimated and est.roll_sigma_rad is not None and result.span_s < ROLL_RELIABLE_S:
        lines.append(
            f"UNRELIABLE roll: {math.degrees(est.extrinsics.roll_rad):.2f} deg from a "
            f"{result.span_s:.1f} s drive; over a short drive lane wander reads as up to 3 deg "
            f"of roll (docs/camera.md; reliable to 0.75 deg over {ROLL_RELIABLE_S:.0f} s): "
            "pass --roll-deg 0 for a level mount"
        )
    return lines
