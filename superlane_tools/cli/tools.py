"""`slt cat` and `slt filter`: look at decoded messages, write a trimmed recording."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from superlane_tools.cli._common import (
    EXIT_CODES_HELP,
    cli_errors,
    exit_with,
    note,
    report_lost,
    report_skipped,
)
from superlane_tools.cli._outputs import new_output, overwrite_option

TIME_HELP = "seconds after the first message (12.5), ISO 8601 (2018-08-02T15:34:47Z) or epoch ns"


def cat_cmd(
    recording: Annotated[
        Path,
        typer.Argument(
            help="MCAP file, ROS 1 .bag, ROS 2 bag folder, CAN log or NMEA log.",
            show_default=False,
        ),
    ],
    topics: Annotated[
        list[str] | None,
        typer.Option(
            "--topics", "-t", metavar="REGEX", help="Only topics matching REGEX (repeatable: any)."
        ),
    ] = None,
    as_json: Annotated[bool, typer.Option("--json", help="One JSON object per line.")] = False,
    start: Annotated[str | None, typer.Option(metavar="TIME", help=f"Start: {TIME_HELP}.")] = None,
    end: Annotated[
        str | None, typer.Option(metavar="TIME", help=f"End (exclusive): {TIME_HELP}.")
    ] = None,
    limit: Annotated[
        int | None, typer.Option("--limit", "-n", help="Stop after N messages.", min=1)
    ] = None,
    full_bytes: Annotated[
        bool, typer.Option(help="Print whole byte arrays (base64), not just their length.")
    ] = False,
) -> None:
    """Print decoded messages, one per line, in log-time order."""
    from superlane_tools.commands.cat import CatParams, run

    params = CatParams(recording, tuple(topics or ()), as_json, start, end, limit, full_bytes)
    with cli_errors():
        result = run(params, typer.echo)
    exit_with(report_lost(result.skipped, result.nothing_read, recording))


def filter_cmd(
    recording: Annotated[
        Path,
        typer.Argument(
            help="MCAP file, ROS 1 .bag, ROS 2 bag folder or .db3 file.", show_default=False
        ),
    ],
    out: Annotated[
        Path,
        typer.Option(
            "--out",
            "-o",
            help=(
                "Output: OUT.mcap, OUT.bag for a ROS 1 bag, or a folder OUT "
                "for a ROS 2 bag (same storage)."
            ),
        ),
    ],
    topics: Annotated[
        list[str] | None,
        typer.Option(
            "--topics", "-t", metavar="REGEX", help="Keep topics matching REGEX (repeatable: any)."
        ),
    ] = None,
    exclude: Annotated[
        list[str] | None,
        typer.Option(metavar="REGEX", help="Drop topics matching REGEX (repeatable: any)."),
    ] = None,
    start: Annotated[str | None, typer.Option(metavar="TIME", help=f"Start: {TIME_HELP}.")] = None,
    end: Annotated[
        str | None, typer.Option(metavar="TIME", help=f"End (exclusive): {TIME_HELP}.")
    ] = None,
    overwrite: Annotated[bool, overwrite_option()] = False,
) -> None:
    """Write a trimmed copy of a recording: message definitions, metadata, attachments kept."""
    from superlane_tools.commands.filter import FilterParams, run

    guard = new_output(out, overwrite, [recording])
    with cli_errors():
        patterns = tuple(topics or ()), tuple(exclude or ())
        result = run(FilterParams(recording, out, *patterns, start, end, guard))
    for topic, count in sorted(result.counts.items()):
        note(f"{topic}: {count} messages")
    kind = {"ros1": "ROS 1 bag", "ros2": "ROS 2 bag"}.get(result.output_format, "MCAP")
    note(
        f"wrote {result.path} ({kind}, {sum(result.counts.values())} messages, "
        f"{result.metadata} metadata records, {result.attachments} attachments)"
    )
    exit_with(report_skipped(result.skipped))


def register(app: typer.Typer) -> None:
    """Add ``slt cat`` and ``slt filter`` to the root app."""
    app.command(
        "cat",
        help=(
            "Print a recording's decoded messages, one per line (--json: JSON lines), "
            f"optionally only some topics and a time range.\n\n{EXIT_CODES_HELP}"
        ),
    )(cat_cmd)
    app.command(
        "filter",
        help=(
            "Write a trimmed MCAP, ROS 1 bag or ROS 2 bag: topics by regular expression, a time "
            f"range; payloads copied byte for byte, written atomically.\n\n{EXIT_CODES_HELP}"
        ),
    )(filter_cmd)
