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
from superlane_tools.commands.camera import ProfileOutput
from superlane_tools.errors import SltError

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
    from superlane_tools.commands.camera import profiles

    with cli_errors():
        for name, cam in profiles():
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
    from superlane_tools.commands.camera import show

    with cli_errors():
        typer.echo(show(camera), nl=False)


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
    from superlane_tools.commands.camera import KittiParams, from_kitti

    with cli_errors():
        check_new_output(out, overwrite, [calib])
        guard = new_output(out, overwrite, replaces=True)
        params = KittiParams(
            calib, width, height, camera_height_m, name, out, command_line(), guard
        )
        _print_profile(from_kitti(params))


def _print_profile(output: ProfileOutput) -> None:
    if output.written is None:
        typer.echo(output.text, nl=False)
        return
    note(f"wrote {output.written}")


def _check_board(value: str) -> str:
    """Typer callback for ``--board``: ``9by6`` is a bad value (exit 2), before any work."""
    from superlane_tools.commands.camera import check_board

    try:
        check_board(value)
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
    from superlane_tools.commands.camera import CalibrateParams, calibrate

    with cli_errors():
        check_new_output(out, overwrite, images)
        guard = new_output(out, overwrite, replaces=True)
        params = CalibrateParams(
            images, board, square, height_m, pitch_deg, name, out, command_line(), guard
        )
        result = calibrate(params)
        _print_profile(result.profile)
    note(f"reprojection error {result.rms_px:.3f} px RMS over {result.views} views")
    exit_with(report_skipped(result.rejected))


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
    from superlane_tools.commands.camera_estimate.run import EstimateParams, run

    with cli_errors():
        params = EstimateParams(
            recording,
            out,
            lane_width,
            intrinsics,
            focal_px,
            hfov,
            frames,
            roll_deg,
            topic,
            name,
            command_line(),
            lambda target: new_output(target, overwrite, [recording], replaces=True),
        )
        output = run(params)
        _print_profile(ProfileOutput(output.text, output.written))
    _print_estimate(output.result)
    for line in output.caveats:
        note(line)


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


def register(app: typer.Typer) -> None:
    """Add the ``camera`` command group to the root app."""
    app.add_typer(camera_app, name="camera")
