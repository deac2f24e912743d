"""`slt info`: topics, message counts, rates, gaps and stamp offsets of a recording."""

from __future__ import annotations

import json
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from superlane_tools.cli._common import EXIT_CODES_HELP, cli_errors, console, progress
from superlane_tools.errors import ExitCode

if TYPE_CHECKING:
    from superlane_tools.recording.summary import RecordingSummary


def _utc(ns: int | None) -> str:
    if ns is None:
        return "-"
    return datetime.fromtimestamp(ns / 1e9, tz=UTC).strftime("%Y-%m-%d %H:%M:%S.%f")[:-3]


def _num(value: float | None, fmt: str) -> str:
    return "-" if value is None else format(value, fmt)


def _print_table(summary: RecordingSummary) -> None:
    from rich.console import Console
    from rich.table import Table

    # A terminal gets the table folded to its width; pipes and files get it whole.
    out = console if console.is_terminal else Console(highlight=False, width=200)
    out.print(
        f"{summary.path}  [{summary.container}]  {summary.message_count} messages, "
        f"{summary.duration_s:.3f} s, {_utc(summary.start_ns)} .. {_utc(summary.end_ns)} UTC",
        markup=False,
        highlight=False,
    )
    table = Table(show_lines=False)
    for name, justify in (
        ("topic", "left"),
        ("type", "left"),
        ("enc", "left"),
        ("count", "right"),
        ("rate Hz", "right"),
        ("max gap s", "right"),
        ("duration s", "right"),
        ("stamp-log ms", "right"),
    ):
        table.add_column(name, justify=justify, overflow="fold")  # type: ignore[arg-type]
    for t in summary.topics:
        table.add_row(
            t.topic,
            t.msgtype,
            t.encoding,
            str(t.count),
            _num(t.median_rate_hz, ".2f"),
            _num(t.largest_gap_s, ".3f"),
            f"{t.duration_s:.3f}",
            _num(t.median_stamp_offset_ms, ".1f"),
        )
    out.print(table)


def info(
    recording: Annotated[
        Path,
        typer.Argument(
            help="MCAP file, ROS 1 .bag, ROS 2 bag folder, CAN log or NMEA log.",
            show_default=False,
        ),
    ],
    as_json: Annotated[
        bool, typer.Option("--json", help="Print the summary as JSON instead of a table.")
    ] = False,
) -> None:
    """Show topics, types, counts, median rates, largest gaps and header-stamp offsets."""
    from superlane_tools.cli._common import report_skipped
    from superlane_tools.recording import open_recording, summarize

    with cli_errors(), open_recording(recording) as rec:
        expected = [t.message_count for t in rec.topics()]
        total = sum(c for c in expected if c is not None) if None not in expected else None
        with progress("reading", total, "messages") as bar:
            summary = summarize(rec, progress=bar.update)
    if as_json:
        typer.echo(json.dumps(summary.to_dict(), indent=2))
    else:
        _print_table(summary)
    code = report_skipped(summary.skipped)
    if code != ExitCode.OK:
        raise typer.Exit(int(code))


def register(app: typer.Typer) -> None:
    """Add ``slt info`` to the root app."""
    app.command(
        "info",
        help=(
            "Summarize a recording: per topic the message type, encoding, count, median rate, "
            f"largest gap, time span and header-stamp minus log-time offset.\n\n{EXIT_CODES_HELP}"
        ),
    )(info)
