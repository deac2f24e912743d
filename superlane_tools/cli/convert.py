"""`slt convert`: a dashcam video and GNSS/CAN/signal logs into one MCAP recording."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from superlane_tools.cli._common import (
    EXIT_CODES_HELP,
    camera_option,
    cli_errors,
    command_line,
    exit_with,
    note,
    report_skipped,
)
from superlane_tools.cli._outputs import new_output, overwrite_option


def convert_cmd(
    inputs: Annotated[
        list[Path],
        typer.Argument(
            help="Video (.mp4/.mkv), NMEA log, .gpx, CAN log (candump/.asc/.blf), .csv.",
            show_default=False,
        ),
    ],
    out: Annotated[Path, typer.Option("--out", "-o", help="Output .mcap file.")],
    offset: Annotated[
        list[str] | None,
        typer.Option(
            metavar="FILE=SECONDS",
            help="Add SECONDS to FILE's times to align it (repeatable); default: a shared clock.",
        ),
    ] = None,
    kind: Annotated[
        list[str] | None,
        typer.Option(
            metavar="FILE=KIND",
            help="What FILE holds when its name does not say: video, nmea, gpx, can or csv.",
        ),
    ] = None,
    video_start: Annotated[
        str | None,
        typer.Option(
            metavar="TIME",
            help="Time of the first video frame (ISO 8601 or epoch ns); "
            "default: the container's creation_time, else 0.",
        ),
    ] = None,
    fps: Annotated[
        float | None,
        typer.Option(
            help="Frame times from this rate (start + i/fps), not the container.", min=0.1
        ),
    ] = None,
    camera: Annotated[
        str | None,
        camera_option(
            "Camera profile/YAML of the video: adds CameraInfo and the slt_camera record."
        ),
    ] = None,
    overwrite: Annotated[bool, overwrite_option()] = False,
) -> None:
    """Convert a video and side logs, or any log alone, into one MCAP for slt and Foxglove."""
    from superlane_tools.commands.convert import ConvertParams, run

    with cli_errors():
        params = ConvertParams(
            inputs,
            out,
            offset or [],
            kind or [],
            video_start,
            fps,
            camera,
            command_line(),
            new_output(out, overwrite, inputs),
        )
        result = run(params)
    for topic, count in sorted(result.counts.items()):
        note(f"{topic}: {count} messages")
    for line in result.notes:
        note(line)
    note(f"time alignment: {result.alignment.get('clock', '')}")
    note(f"wrote {result.path}")
    exit_with(report_skipped(result.skipped))


def register(app: typer.Typer) -> None:
    """Add ``slt convert`` to the root app."""
    app.command(
        "convert",
        help=(
            "Convert an MP4/MKV video with optional NMEA/GPX GNSS, CAN (candump/ASC/BLF) and "
            "CSV signal logs, or any of those logs alone, into one MCAP (ROS 2 CDR: "
            "foxglove_msgs/CompressedVideo, NavSatFix, can_msgs/Frame, std_msgs/Float64). The "
            f"time alignment is written to the slt_convert metadata record.\n\n{EXIT_CODES_HELP}"
        ),
    )(convert_cmd)
