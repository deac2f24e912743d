"""`slt camera`: list and show camera profiles, convert KITTI calibration files."""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from superlane_tools.cli._common import (
    check_camera,
    cli_errors,
    command_line,
    exit_with,
    note,
    report_skipped,
)
from superlane_tools.cli._outputs import check_new_output, new_output, overwrite_option
from superlane_tools.errors import SltError
from superlane_tools.records import Skipped

if TYPE_CHECKING:
    from superlane_tools.commands.camera_estimate import CameraEstimate

camera_app = typer.Typer(
    name="camera",
    help=(
        "Camera profiles: list the bundled ones, show one, convert KITTI calibration files, "
        "calibrate from chessboard photos, estimate the mounting from a recording."
    ),
    no_args_is_help=True,
    rich_markup_mode=None,
)


@camera_app.command("list")
def list_cmd() -> None:
    """List the bundled camera profiles (usable wherever a camera NAME|YAML is asked for)."""
    from superlane_tools.camera import list_profiles, load_camera

    with cli_errors():
        for name in list_profiles():
            cam = load_camera(name)
            k, e = cam.intrinsics, cam.extrinsics
            typer.echo(
                f"{name:<12} {k.width}x{k.height}  f={k.fx:.1f}px  height={e.height_m:.3f}m  "
                f"pitch={e.pitch_rad:.4f}rad"
            )


@camera_app.command("show")
def show_cmd(
    camera: Annotated[
        str,
        typer.Argument(help="Bundled profile name or camera YAML file.", callback=check_camera),
    ],
) -> None:
    """Print a camera profile as YAML, with derived values (horizon, field of view) as comments."""
    from superlane_tools.camera import camera_to_yaml, load_camera

    with cli_errors():
        cam = load_camera(camera)
        k = cam.intrinsics
        hfov = math.degrees(2.0 * math.atan(k.width / (2.0 * k.fx)))
        vfov = math.degrees(2.0 * math.atan(k.height / (2.0 * k.fy)))
        comment = (
            f"horizon row: {cam.horizon_row():.1f} px\n"
            f"field of view: {hfov:.1f} x {vfov:.1f} deg (undistorted)"
        )
        typer.echo(camera_to_yaml(cam, comment=comment), nl=False)


@camera_app.command("from-kitti")
def from_kitti_cmd(
    calib: Annotated[
        Path, typer.Argument(help="KITTI calibration file (P2, R0_rect, Tr_velo_to_cam).")
    ],
    width: Annotated[int, typer.Option(help="Image width in pixels.", min=1)] = 1242,
    height: Annotated[int, typer.Option(help="Image height in pixels.", min=1)] = 375,
    camera_height_m: Annotated[
        float, typer.Option(help="Camera height above the road in metres (KITTI: 1.65).", min=0.01)
    ] = 1.65,
    name: Annotated[str, typer.Option(help="Profile name written into the YAML.")] = "kitti",
    out: Annotated[
        Path | None, typer.Option(help="Write the YAML here instead of printing it.")
    ] = None,
    overwrite: Annotated[bool, overwrite_option()] = False,
) -> None:
    """Convert a KITTI calibration file into a camera-2 profile (YAML)."""
    from superlane_tools.camera import camera_to_yaml, kitti_camera

    with cli_errors():
        check_new_output(out, overwrite, [calib])
        cam = kitti_camera(calib, width, height, camera_height_m, name)
        comment = (
            f"KITTI camera 2 from {calib.name}: intrinsics from P2, angles from "
            f"R0_rect @ Tr_velo_to_cam,\nheight {camera_height_m:g} m (KITTI mount height). "
            f"Written by: {command_line()}"
        )
        text = camera_to_yaml(cam, comment=comment)
        _write_profile(out, text, overwrite)


def _image_list(images: list[Path]) -> list[Path]:
    out: list[Path] = []
    for path in images:
        if path.is_dir():
            out.extend(
                sorted(p for p in path.iterdir() if p.suffix.lower() in {".jpg", ".jpeg", ".png"})
            )
        else:
            out.append(path)
    return out


def _write_profile(out: Path | None, text: str, overwrite: bool) -> None:
    from superlane_tools.reporting import write_text_atomic

    if out is None:
        typer.echo(text, nl=False)
        return
    with new_output(out, overwrite, replaces=True):
        write_text_atomic(out, text)
    note(f"wrote {out}")


def _check_board(value: str) -> str:
    """Typer callback for ``--board``: ``9by6`` is a bad value (exit 2), before any work."""
    from superlane_tools.camera.calibration import parse_board

    try:
        parse_board(value)
    except SltError as err:
        raise typer.BadParameter(str(err)) from err
    return value


@camera_app.command("calibrate")
def calibrate_cmd(
    images: Annotated[
        list[Path],
        typer.Argument(help="Chessboard photos, or folders of them.", show_default=False),
    ],
    board: Annotated[
        str,
        typer.Option(
            metavar="COLSxROWS", help="Inner corners per row x per column.", callback=_check_board
        ),
    ] = "9x6",
    square: Annotated[float, typer.Option(help="Square side, metres.", min=1e-6)] = 0.025,
    height_m: Annotated[
        float, typer.Option(help="Camera height above the road, metres (until estimated).")
    ] = 1.3,
    pitch_deg: Annotated[
        float, typer.Option(help="Downward pitch, degrees (until estimated).")
    ] = 0.0,
    name: Annotated[str, typer.Option(help="Profile name written into the YAML.")] = "calibrated",
    out: Annotated[
        Path | None,
        typer.Option("--out", "-o", help="Write the profile YAML here instead of printing it."),
    ] = None,
    overwrite: Annotated[bool, overwrite_option()] = False,
) -> None:
    """Calibrate intrinsics and distortion from chessboard photos (OpenCV) into a profile."""
    import yaml

    from superlane_tools.camera import camera_to_yaml
    from superlane_tools.camera.calibration import calibrate_chessboard, parse_board
    from superlane_tools.camera.model import CameraModel, Extrinsics
    from superlane_tools.errors import UsageError

    with cli_errors():
        check_new_output(out, overwrite, images)
        paths = _image_list(images)
        if not paths:
            raise UsageError("no images given (JPEG or PNG files, or folders of them)")
        result = calibrate_chessboard(paths, parse_board(board), square)
        cam = CameraModel(
            result.intrinsics, Extrinsics(height_m, math.radians(pitch_deg)), name=name
        )
        comment = (
            f"Calibrated from {len(result.used)} of {len(paths)} chessboard photos: "
            f"RMS reprojection error {result.rms_px:.3f} px.\n"
            f"Extrinsics are assumed (height {height_m:g} m, pitch {pitch_deg:g} deg): "
            "run `slt camera estimate` on a recording to estimate them.\n"
            f"Written by: {command_line()}"
        )
        text = camera_to_yaml(cam, comment=comment) + yaml.safe_dump(
            {"calibration": result.summary()}, sort_keys=False
        )
        _write_profile(out, text, overwrite)
    note(f"reprojection error {result.rms_px:.3f} px RMS over {len(result.used)} views")
    names: dict[str, list[str]] = {}
    for path, reason in result.rejected:
        names.setdefault(f"photos, {reason}", []).append(path.name)
    lost = [Skipped(kind, ", ".join(photos), len(photos)) for kind, photos in names.items()]
    exit_with(report_skipped(lost))


ROLL_RELIABLE_S = 60.0
"""Drive length, seconds, below which an estimated roll is flagged: docs/camera.md measures
lane wander over short drives as up to 3 degrees of roll, and the roll within 0.75 degrees on a
60 s drive."""


@camera_app.command("estimate")
def estimate_cmd(
    recording: Annotated[
        Path,
        typer.Argument(
            help="Recording with a camera topic (images or video), or a dashcam video file."
        ),
    ],
    lane_width: Annotated[
        float, typer.Option(help="Lane width of the road driven, metres.", min=0.5)
    ] = 3.7,
    intrinsics: Annotated[
        str | None,
        typer.Option(
            metavar="PROFILE", help="Camera profile or YAML with the intrinsics (calibrate)."
        ),
    ] = None,
    focal_px: Annotated[
        float | None, typer.Option(help="Focal length, pixels at the recorded size.")
    ] = None,
    hfov: Annotated[
        float | None,
        typer.Option(
            help=(
                "Horizontal field of view, degrees. With no intrinsics at all, the focal length "
                "is measured from the dashed markings' motion at GNSS speed where possible, "
                "else 60 degrees is assumed."
            )
        ),
    ] = None,
    frames: Annotated[int, typer.Option(help="Frames to use, spread evenly.", min=3)] = 60,
    roll_deg: Annotated[
        float | None,
        typer.Option(
            help=(
                "Known roll, degrees (left side up positive). By default the roll is estimated, "
                "assuming the camera rides at the lane centre on average."
            ),
        ),
    ] = None,
    topic: Annotated[str | None, typer.Option(help="Camera topic (default: the first).")] = None,
    name: Annotated[str, typer.Option(help="Profile name written into the YAML.")] = "estimated",
    out: Annotated[
        Path | None,
        typer.Option(
            "--out",
            "-o",
            help="Profile YAML to write; '-' prints it. Default: <recording stem>.camera.yaml "
            "beside the recording, the profile `--camera auto` reads.",
            show_default=False,
        ),
    ] = None,
    overwrite: Annotated[bool, overwrite_option()] = False,
) -> None:
    """Estimate pitch, yaw, roll and height from the lane lines and the lane width."""
    from superlane_tools.recording.calibration import camera_sidecar

    target = None if str(out) == "-" else out if out is not None else camera_sidecar(recording)
    check_new_output(target, overwrite, [recording])  # before the heavy imports and any work
    import yaml

    from superlane_tools.camera import camera_to_yaml, load_camera
    from superlane_tools.commands.camera_estimate import estimate_camera
    from superlane_tools.config_files import load_document

    with cli_errors():
        known = load_camera(intrinsics).intrinsics if intrinsics is not None else None
        result = estimate_camera(
            recording,
            intrinsics=known,
            focal_px=focal_px,
            hfov_deg=hfov,
            lane_width_m=lane_width,
            max_frames=frames,
            topic=topic,
            name=name,
            roll_rad=None if roll_deg is None else math.radians(roll_deg),
        )
        est = result.estimate
        caveats = _estimate_caveats(result, lane_width, roll_deg is None)
        comment = (
            f"Extrinsics estimated from {est.frames_used} of {est.frames_seen} frames of "
            f"{recording.name}.\nIntrinsics: {result.intrinsics_source}.\n"
            + "".join(f"{line}\n" for line in caveats)
            + f"Written by: {command_line()}"
        )
        blocks: dict[str, object] = {}
        if intrinsics is not None and Path(intrinsics).is_file():
            source = load_document(intrinsics, "intrinsics file", ".yaml")
            if isinstance(source, dict) and "calibration" in source:  # keep the chessboard report
                blocks["calibration"] = source["calibration"]
        blocks["estimate"] = {
            **est.summary(),
            "intrinsics": result.intrinsics_source,
            "span_s": round(result.span_s, 2),
            "assumptions": caveats,
        }
        text = camera_to_yaml(result.camera, comment=comment) + yaml.safe_dump(
            blocks, sort_keys=False
        )
        _write_estimate(target, out is None, text, overwrite)
    _print_estimate(result)
    for line in caveats:
        note(line)


def _write_estimate(target: Path | None, default: bool, text: str, overwrite: bool) -> None:
    """Write the estimated profile; a default path in a read-only folder names ``-o``."""
    from superlane_tools.reporting import OutputError

    try:
        _write_profile(target, text, overwrite)
    except OutputError as err:
        if not default:
            raise
        raise OutputError(
            f"{err} (the recording's folder; pass -o PATH, then --camera PATH)"
        ) from err


def _print_estimate(result: CameraEstimate) -> None:
    est = result.estimate
    e = est.extrinsics
    roll = f"roll {math.degrees(e.roll_rad):.2f} deg ({est.roll_method})"
    if est.roll_sigma_rad is not None:
        roll = f"roll {math.degrees(e.roll_rad):.2f} +- {math.degrees(est.roll_sigma_rad):.2f} deg"
    note(
        f"pitch {math.degrees(e.pitch_rad):.2f} +- {math.degrees(est.pitch_sigma_rad):.2f} deg, "
        f"yaw {math.degrees(e.yaw_rad):.2f} +- {math.degrees(est.yaw_sigma_rad):.2f} deg, "
        f"{roll}, "
        f"height {e.height_m:.3f} +- {est.height_sigma_m:.3f} m (per-frame spread; "
        f"{est.frames_used} frames); intrinsics: {result.intrinsics_source}"
    )


def _estimate_caveats(
    result: CameraEstimate, lane_width_m: float, roll_estimated: bool
) -> list[str]:
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


def register(app: typer.Typer) -> None:
    """Add the ``camera`` command group to the root app."""
    app.add_typer(camera_app, name="camera")
