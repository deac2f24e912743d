"""`slt extract`: frames, camera info, CAN (raw and DBC-decoded) and GNSS/RTK tables."""

from __future__ import annotations

import inspect
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from superlane_tools.cli._common import (
    EXIT_CODES_HELP,
    cli_errors,
    command_line,
    console,
    err_console,
    exit_with,
    progress,
    report_skipped,
)
from superlane_tools.errors import ExitCode, UsageError

if TYPE_CHECKING:
    from superlane_tools.geo import GeodeticOrigin


def _origin(text: str | None) -> GeodeticOrigin | None:
    """Parse ``--origin``; a malformed value is a usage error."""
    from superlane_tools.geo import GeoError, parse_origin

    if text is None:
        return None
    try:
        return parse_origin(text)
    except GeoError as err:
        raise UsageError(f"--origin: {err}") from err


def extract_cmd(
    recording: Annotated[
        Path,
        typer.Argument(
            help="MCAP file, ROS 1 .bag, ROS 2 bag folder, CAN log or NMEA log.",
            show_default=False,
        ),
    ],
    out: Annotated[
        Path, typer.Option("--out", "-o", help="Output folder (created).", show_default=False)
    ],
    topics: Annotated[
        list[str] | None,
        typer.Option(
            "--topics", "-t", metavar="TOPIC", help="Only these topics (repeatable); default: all."
        ),
    ] = None,
    start: Annotated[
        float | None,
        typer.Option(help="Start, seconds after the recording's first message.", min=0.0),
    ] = None,
    end: Annotated[
        float | None,
        typer.Option(help="End (exclusive), seconds after the recording's first message."),
    ] = None,
    dbc: Annotated[
        list[Path] | None,
        typer.Option(
            "--dbc",
            metavar="FILE",
            help="DBC file to decode CAN signals with (repeatable).",
            exists=True,
            dir_okay=False,
        ),
    ] = None,
    frames: Annotated[
        str, typer.Option("--frames", help="Image file format: jpg, png or none (index only).")
    ] = "jpg",
    every: Annotated[int, typer.Option(help="Keep every Nth frame of each topic.", min=1)] = 1,
    origin: Annotated[
        str | None,
        typer.Option(help="ENU origin 'lat,lon[,alt]' (degrees, metres); default: first fix."),
    ] = None,
    config: Annotated[
        Path | None,
        typer.Option(
            "--config",
            help="YAML {frames: [...], camera_info: [...], can: [...], gnss: [...]}.",
            exists=True,
            dir_okay=False,
        ),
    ] = None,
) -> None:
    """Extract frames, camera info, CAN frames/signals and GNSS fixes to files and Parquet.

    Streams are found by message type; --topics restricts them and --config assigns topics to
    kinds explicitly. Writes frames/<topic>/<index>.<ext>, frames.parquet, camera_info.parquet,
    can_raw.parquet, can_signals.parquet (with --dbc) and rtk.parquet (with ENU east/north/up,
    speed and heading).
    """
    from superlane_tools.pipeline import ExtractConfig, extract, load_stream_config

    with cli_errors():
        streams = load_stream_config(config) if config is not None else {}
        settings = ExtractConfig(
            topics=tuple(topics or ()),
            streams=streams,
            start_s=start,
            end_s=end,
            dbc_paths=tuple(dbc or ()),
            frame_format=frames.lower(),
            every=every,
            origin=_origin(origin),
        )

        def show_dbc(name: str, loaded: object) -> None:
            repairs = getattr(loaded, "repairs", [])
            err_console.print(
                f"slt: dbc {name}: loaded with {len(repairs)} repair(s)", markup=False
            )
            for line in repairs:
                err_console.print(f"slt: dbc {name}: {line}", markup=False)

        with progress("extract", unit="messages") as bar:
            result = extract(
                recording,
                out,
                settings,
                command=command_line(),
                progress=bar.update,
                on_dbc=show_dbc,
            )
    for kind, names in result.selected.items():
        if names:
            console.print(f"{kind}: {', '.join(names)}", markup=False)
    counts = ", ".join(f"{k} {v}" for k, v in result.counts.items() if v)
    console.print(f"extracted: {counts or 'nothing'} -> {out}", markup=False)
    for path in result.outputs:
        console.print(f"wrote {path}", markup=False)
    code = report_skipped(result.skipped)
    if not result.outputs:
        code = ExitCode.ERROR
    exit_with(code)


def register(app: typer.Typer) -> None:
    """Add this module's commands to the root app."""
    app.command(
        "extract",
        help=inspect.cleandoc(extract_cmd.__doc__ or "") + f"\n\n{EXIT_CODES_HELP}",
    )(extract_cmd)
