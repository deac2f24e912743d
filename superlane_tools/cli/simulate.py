"""`slt simulate`: synthetic drives with exact ground truth, and training datasets."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from superlane_tools.cli._common import (
    cli_errors,
    command_line,
    console,
    fail,
    progress,
)
from superlane_tools.cli._outputs import new_output, overwrite_option
from superlane_tools.errors import ExitCode

simulate_app = typer.Typer(
    help="Simulate drives (camera + CAN + RTK recordings with ground truth) and datasets.",
    no_args_is_help=False,
    pretty_exceptions_show_locals=False,
    rich_markup_mode=None,
)


# The options of `simulate`, as Typer reads them from the annotations.
_Scenario = Annotated[
    str | None, typer.Option("--scenario", "-s", help="Scenario name (see --list).")
]
_Out = Annotated[
    Path | None,
    typer.Option("--out", "-o", help="Recording path (.mcap, .bag, or ROS 2 bag folder)."),
]
_Duration = Annotated[float, typer.Option(help="Drive length, seconds.")]
_Seed = Annotated[int, typer.Option(help="Seed of all random choices.")]
_Fmt = Annotated[str, typer.Option("--format", help="mcap, ros1 or ros2.")]
_Width = Annotated[int, typer.Option(help="Image width, pixels.")]
_Height = Annotated[int, typer.Option(help="Image height, pixels.")]
_Fps = Annotated[float, typer.Option(help="Camera frame rate, Hz.")]
_JpegQuality = Annotated[
    int | None, typer.Option(help="JPEG quality 1-100 (default: the scenario's).")
]
_RtkMode = Annotated[
    str, typer.Option(help="GNSS fix quality: fixed (RTK, cm), float or standalone (m).")
]
_RtkRate = Annotated[float, typer.Option(help="GNSS fix rate, Hz (10-20).")]
_Video = Annotated[
    str | None,
    typer.Option(
        metavar="FORMAT",
        help="Write the camera as foxglove_msgs/CompressedVideo (h264 or h265), not JPEG.",
    ),
]
_RtkDropouts = Annotated[float, typer.Option(help="GNSS outages per minute (1-4 s each).")]
_RtkMultipath = Annotated[
    float,
    typer.Option(help="GNSS multipath episodes per minute (2-8 s of 0.3-1.5 m jumps, float)."),
]
_Labels = Annotated[
    bool, typer.Option("--labels", help="Also write label and corridor PNGs per frame.")
]
_SpeedKph = Annotated[
    bool, typer.Option("--speed-kph", help="Send the CAN speed in km/h (slt_vehicle_kph.dbc).")
]
_Imu = Annotated[bool, typer.Option("--imu", help="Also write an IMU topic (/imu/data).")]
_SecondBus = Annotated[
    bool,
    typer.Option(
        "--second-bus",
        help="Mobileye lanes on a second CAN bus (/can1/rx) with an id colliding with 0x180.",
    ),
]
_MobileyeLatency = Annotated[
    float,
    typer.Option(
        "--mobileye-latency",
        help="Delay of the Mobileye lane messages after their camera frame, seconds (0-1).",
    ),
]
_List = Annotated[bool, typer.Option("--list", help="List the scenarios and exit.")]
_Overwrite = Annotated[bool, overwrite_option()]


@simulate_app.callback(invoke_without_command=True)
def simulate(
    ctx: typer.Context,
    scenario: _Scenario = None,
    out: _Out = None,
    duration: _Duration = 20.0,
    seed: _Seed = 0,
    fmt: _Fmt = "mcap",
    width: _Width = 1280,
    height: _Height = 720,
    fps: _Fps = 15.0,
    jpeg_quality: _JpegQuality = None,
    rtk_mode: _RtkMode = "fixed",
    rtk_rate: _RtkRate = 10.0,
    video: _Video = None,
    rtk_dropouts: _RtkDropouts = 0.0,
    rtk_multipath: _RtkMultipath = 0.0,
    labels: _Labels = False,
    speed_kph: _SpeedKph = False,
    imu: _Imu = False,
    second_bus: _SecondBus = False,
    mobileye_latency: _MobileyeLatency = 0.1,
    list_: _List = False,
    overwrite: _Overwrite = False,
) -> None:
    """Simulate one drive: `slt simulate --scenario NAME --out drive.mcap`."""
    if ctx.invoked_subcommand is not None:
        return
    from superlane_tools.commands import simulate as command

    if list_:
        names = command.scenarios()
        width_name = max(len(n) for n, _ in names)
        for name, description in names:
            console.print(f"{name:<{width_name}}  {description}", markup=False, soft_wrap=True)
        return
    if scenario is None or out is None:
        fail(
            "give --scenario NAME and --out PATH (or --list, or the dataset command)",
            ExitCode.USAGE,
        )
    with cli_errors():
        params = command.DriveParams(
            scenario,
            out,
            duration,
            seed,
            fmt,
            width,
            height,
            fps,
            jpeg_quality,
            rtk_mode,
            rtk_rate,
            video,
            rtk_dropouts,
            rtk_multipath,
            labels,
            speed_kph,
            imu,
            second_bus,
            mobileye_latency,
            command_line(),
            new_output(out, overwrite),
        )
        result = command.drive(params, lambda: progress(f"simulate {scenario}", unit="frames"))
        o = result.outputs
        console.print(
            f"wrote {o.recording} ({result.frames} frames, {result.messages} messages), "
            f"{o.groundtruth.name}, {o.tusimple.name}"
            + (f", {o.labels_dir.name}/" if labels else ""),
            markup=False,
            soft_wrap=True,
        )


@simulate_app.command("dataset")
def dataset(
    out: Annotated[Path, typer.Option("--out", "-o", help="Output folder (created).")],
    frames: Annotated[int, typer.Option(help="Number of samples.")],
    scenarios: Annotated[
        list[str] | None,
        typer.Option("--scenarios", help="Scenario names (repeat or comma-separate; default all)."),
    ] = None,
    seed: Annotated[int, typer.Option(help="Seed of all random choices.")] = 0,
    width: Annotated[int, typer.Option(help="Image width, pixels.")] = 1280,
    height: Annotated[int, typer.Option(help="Image height, pixels.")] = 720,
    image_format: Annotated[str, typer.Option(help="Image files: jpg or png.")] = "jpg",
    randomize: Annotated[
        float, typer.Option(help="Domain randomisation strength 0-1 (colours, textures, camera).")
    ] = 1.0,
    overwrite: Annotated[bool, overwrite_option()] = False,
) -> None:
    """Write a training set: images, leaf-id masks, corridor masks and index.parquet."""
    from superlane_tools.commands import simulate as command

    with cli_errors():
        params = command.DatasetParams(
            out,
            frames,
            scenarios or [],
            seed,
            width,
            height,
            image_format,
            randomize,
            command_line(),
            new_output(out, overwrite),
        )
        result = command.dataset(params, lambda: progress("dataset", frames, "samples"))
        console.print(f"wrote {result.samples} samples to {result.folder}", markup=False)


def register(app: typer.Typer) -> None:
    """Add this module's commands to the root app."""
    app.add_typer(simulate_app, name="simulate")
