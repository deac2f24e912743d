"""`slt recover`: a valid, indexed copy of a damaged recording, and what it lost."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer

from superlane_tools.cli._common import (
    EXIT_CODES_HELP,
    cli_errors,
    console,
    exit_with,
    report_skipped,
)
from superlane_tools.cli._outputs import new_output, overwrite_option
from superlane_tools.records import Skipped


def recover_cmd(
    recording: Annotated[
        Path,
        typer.Argument(
            help="Damaged MCAP file, ROS 1 .bag, ROS 2 bag folder or .db3 file.",
            show_default=False,
        ),
    ],
    out: Annotated[
        Path,
        typer.Option(
            "--out",
            "-o",
            help=(
                "Output in the input's format: OUT.mcap for an MCAP, OUT.bag "
                "for a ROS 1 bag, a folder OUT for a ROS 2 bag (same storage)."
            ),
        ),
    ],
    as_json: Annotated[
        bool,
        typer.Option("--json", help="Print what was written and lost as one JSON document."),
    ] = False,
    overwrite: Annotated[bool, overwrite_option()] = False,
) -> None:
    """Write every readable message into a new recording; report what was lost."""
    from superlane_tools.commands.recover import recover

    with cli_errors(), new_output(out, overwrite, [recording]):
        result = recover(recording, out)
    if as_json:
        console.print_json(json.dumps(result.document()))
    else:
        for topic, count in sorted(result.written.items()):
            console.print(f"{topic}: {count} messages", markup=False)
        console.print(
            f"wrote {result.out} ({result.format}, {sum(result.written.values())} messages)",
            markup=False,
        )
    lost = [Skipped(x["what"], x["detail"], x["messages"] or 0) for x in result.lost]
    exit_with(report_skipped(lost))


def register(app: typer.Typer) -> None:
    """Add ``slt recover`` to the root app."""
    app.command(
        "recover",
        help=(
            "Recover a damaged MCAP, ROS 1 bag or ROS 2 bag: write every readable message into "
            "a valid, indexed recording of the same format (like mcap recover and rosbag "
            "reindex) and report what was lost per damaged region and topic (exit 0 nothing "
            f"lost, 3 something lost, 1 nothing readable).\n\n{EXIT_CODES_HELP}"
        ),
    )(recover_cmd)
