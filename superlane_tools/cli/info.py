"""`slt info`: topics, message counts, rates, gaps and stamp offsets of a recording."""

from __future__ import annotations

import json
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from superlane_tools.cli._common import (
    EXIT_CODES_HELP,
    cli_errors,
    console,
    progress,
    report_lost,
)
from superlane_tools.errors import ExitCode

if TYPE_CHECKING:
    from superlane_tools.recording.inspect import CanIdStats, McapFileInfo
    from superlane_tools.recording.summary import RecordingSummary


def _utc(ns: int | None) -> str:
    if ns is None:
        return "-"
    return datetime.fromtimestamp(ns / 1e9, tz=UTC).strftime("%Y-%m-%d %H:%M:%S.%f")[:-3]


def _num(value: float | None, fmt: str) -> str:
    return "-" if value is None else format(value, fmt)


def _size(n: int) -> str:
    value = float(n)
    for unit in ("B", "KiB", "MiB", "GiB"):
        if value < 1024 or unit == "GiB":
            return f"{value:.1f} {unit}" if unit != "B" else f"{n} B"
        value /= 1024
    return f"{n} B"


def _print_file(info: McapFileInfo, mode: str) -> None:
    out = console
    compression = ", ".join(c or "none" for c in info.compression) or "-"
    out.print(
        f"file: {_size(info.size_bytes)}, MCAP profile {info.profile or '-'}, library "
        f"{info.library or '-'}, {info.chunk_count} chunks ({compression}); read from: {mode}",
        markup=False,
        highlight=False,
    )
    for m in info.metadata:
        pairs = ", ".join(f"{k}={v}" for k, v in list(m["data"].items())[:6])
        more = " ..." if len(m["data"]) > 6 else ""
        out.print(f"metadata {m['name']}: {pairs}{more}", markup=False, highlight=False)
    for a in info.attachments:
        out.print(
            f"attachment {a['name']} ({a['media_type']}, {_size(a['size_bytes'])})",
            markup=False,
            highlight=False,
        )


def _print_can_ids(rows: list[CanIdStats]) -> None:
    from rich.console import Console
    from rich.table import Table

    out = console if console.is_terminal else Console(highlight=False, width=200)
    table = Table(show_lines=False)
    for name in ("CAN topic", "id", "count", "rate Hz", "DLC"):
        table.add_column(name, justify="left" if name == "CAN topic" else "right")
    for r in rows:
        table.add_row(
            r.topic,
            f"0x{r.can_id:X}",
            str(r.count),
            _num(r.rate_hz, ".2f"),
            ",".join(str(d) for d in r.dlcs),
        )
    out.print(table)


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
    for t in summary.topics:
        if t.median_rate_hz is None and t.count > 1:  # 0 or 1 message: "-" needs no reason
            out.print(f"rate -: {t.topic}: {t.rate_note}", markup=False, highlight=False)


def info(
    recording: Annotated[
        Path,
        typer.Argument(
            help="MCAP file, ROS 1 .bag, ROS 2 bag folder, CAN log, NMEA log or video (.mp4).",
            show_default=False,
        ),
    ],
    as_json: Annotated[
        bool, typer.Option("--json", help="Print the summary as JSON instead of a table.")
    ] = False,
    scan: Annotated[
        bool,
        typer.Option(
            "--scan",
            help="Read every message (gaps, stamp offsets, CAN ids) even when an MCAP has a "
            "summary section; without it such a file is answered from its summary alone.",
        ),
    ] = False,
) -> None:
    """Show topics, types, counts, median rates, largest gaps and header-stamp offsets."""
    from superlane_tools.commands.info import run

    with cli_errors():
        result = run(recording, scan, lambda total: progress("reading", total, "messages"))
    _emit(result.summary, result.file_info, result.read_from, result.can_rows, as_json)
    if result.fast:
        return
    code = report_lost(result.summary.skipped, result.summary.message_count == 0, recording)
    if code != ExitCode.OK:
        raise typer.Exit(int(code))


def _emit(
    summary: RecordingSummary,
    file_info: McapFileInfo | None,
    mode: str,
    can_rows: list[CanIdStats],
    as_json: bool,
) -> None:
    from dataclasses import asdict

    if as_json:
        doc = summary.to_dict()
        doc["read_from"] = mode
        doc["file"] = file_info.to_dict() if file_info is not None else None
        doc["can_ids"] = [asdict(r) for r in can_rows]
        typer.echo(json.dumps(doc, indent=2))
        return
    if file_info is not None:
        _print_file(file_info, mode)
    _print_table(summary)
    if can_rows:
        _print_can_ids(can_rows)


def register(app: typer.Typer) -> None:
    """Add ``slt info`` to the root app."""
    app.command(
        "info",
        help=(
            "Summarize a recording: per topic the message type, encoding, count, median rate, "
            f"largest gap, time span and header-stamp minus log-time offset.\n\n{EXIT_CODES_HELP}"
        ),
    )(info)
