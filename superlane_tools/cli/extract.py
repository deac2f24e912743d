"""`slt extract`: frames, camera info, CAN (raw and DBC-decoded) and GNSS/RTK tables."""

from __future__ import annotations

import inspect
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from superlane_tools.cli._common import (
    EXIT_CODES_HELP,
    check_dbc_specs,
    cli_errors,
    command_line,
    console,
    exit_with,
    note,
    progress,
    report_skipped,
)
from superlane_tools.cli._outputs import new_output, overwrite_option
from superlane_tools.errors import ExitCode

if TYPE_CHECKING:
    from superlane_tools.commands.extract import ExtractResult

DbcFiles = Annotated[
    list[Path] | None,
    typer.Option(
        "--dbc",
        metavar="[BUS=]FILE",
        help="DBC file to decode CAN signals with (repeatable); BUS=FILE (can0=pt.dbc) "
        "binds it to one bus (CAN topic or channel), a plain FILE decodes every bus.",
        callback=check_dbc_specs,
    ),
]
StreamConfig = Annotated[
    Path | None,
    typer.Option(
        "--config",
        help="YAML {frames: [...], camera_info: [...], can: [...], gnss: [...]}.",
        exists=True,
        dir_okay=False,
    ),
]


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
        str | None,
        typer.Option(
            metavar="TIME",
            help="Start: seconds after the first message (12.5), ISO 8601 or epoch ns.",
        ),
    ] = None,
    end: Annotated[
        str | None,
        typer.Option(
            metavar="TIME",
            help="End (exclusive): seconds after the first message, ISO 8601 or epoch ns.",
        ),
    ] = None,
    dbc: DbcFiles = None,
    frames: Annotated[
        str, typer.Option("--frames", help="Image file format: jpg, png or none (index only).")
    ] = "jpg",
    every: Annotated[int, typer.Option(help="Keep every Nth frame of each topic.", min=1)] = 1,
    origin: Annotated[
        str | None,
        typer.Option(help="ENU origin 'lat,lon[,alt]' (degrees, metres); default: first fix."),
    ] = None,
    config: StreamConfig = None,
    verbose: Annotated[
        bool, typer.Option("--verbose", "-v", help="List every DBC repair, not just how many.")
    ] = False,
    overwrite: Annotated[bool, overwrite_option()] = False,
) -> None:
    """Extract frames, camera info, CAN frames/signals and GNSS fixes to files and Parquet.

    Streams are found by message type; --topics restricts them and --config assigns topics to
    kinds explicitly. Writes frames/<topic>/<index>.<ext>, frames.parquet, camera_info.parquet,
    can_raw.parquet, can_signals.parquet (with --dbc) and rtk.parquet (with ENU east/north/up,
    speed and heading).
    """
    from superlane_tools.commands.extract.entry import ExtractOptions, run

    options = ExtractOptions(
        recording,
        out,
        topics or [],
        start,
        end,
        dbc or [],
        frames,
        every,
        origin,
        config,
        verbose,
        command_line(),
        new_output(out, overwrite, [recording]),
    )
    with cli_errors():
        result = run(options, lambda: progress("extract", unit="messages"), note)
    _print(result, out)


def _print(result: ExtractResult, out: Path) -> None:
    """Print what was extracted and written, the notes; exit with the run's code."""
    for kind, names in result.selected.items():
        if names:
            console.print(f"{kind}: {', '.join(names)}", markup=False)
    if result.can_coverage is not None:
        note(result.can_coverage.line())
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
