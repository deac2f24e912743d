"""`slt camera`: list and show camera profiles, convert KITTI calibration files."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated

import typer

from superlane_tools.cli._common import cli_errors, command_line, err_console

camera_app = typer.Typer(
    name="camera",
    help="Camera profiles: list the bundled ones, show one, convert KITTI calibration files.",
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
    camera: Annotated[str, typer.Argument(help="Bundled profile name or camera YAML file.")],
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
) -> None:
    """Convert a KITTI calibration file into a camera-2 profile (YAML)."""
    from superlane_tools.camera import camera_to_yaml, kitti_camera
    from superlane_tools.reporting import write_text_atomic

    with cli_errors():
        cam = kitti_camera(calib, width, height, camera_height_m, name)
        comment = (
            f"KITTI camera 2 from {calib.name}: intrinsics from P2, angles from "
            f"R0_rect @ Tr_velo_to_cam,\nheight {camera_height_m:g} m (KITTI mount height). "
            f"Written by: {command_line()}"
        )
        text = camera_to_yaml(cam, comment=comment)
        if out is None:
            typer.echo(text, nl=False)
        else:
            write_text_atomic(out, text)
            err_console.print(f"wrote {out}", markup=False)


def register(app: typer.Typer) -> None:
    """Add the ``camera`` command group to the root app."""
    app.add_typer(camera_app, name="camera")
