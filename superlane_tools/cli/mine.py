"""`slt mine`: frames worth labelling from reprocess runs, with pre-annotations."""

from __future__ import annotations

import inspect
from pathlib import Path
from typing import Annotated

import typer

from superlane_tools.cli._common import (
    EXIT_CODES_HELP,
    cli_errors,
    command_line,
    console,
    exit_with,
    report_skipped,
)
from superlane_tools.cli._outputs import new_output, overwrite_option


def mine_cmd(
    inputs: Annotated[list[Path], typer.Argument(help="Run folders or batch roots.")],
    out: Annotated[Path, typer.Option("--out", help="Output label set folder.")] = Path("mined"),
    criteria: Annotated[
        str,
        typer.Option(
            "--criteria",
            help="Comma-separated: disagree, availability_drop, fit_quality, lane_change, "
            "curvature_extreme, span, low_light (night / low contrast: decodes every frame of "
            "the recording, so not a default; see docs/compare.md).",
        ),
    ] = "disagree,availability_drop,fit_quality,lane_change,curvature_extreme,span",
    require_all: Annotated[
        bool, typer.Option("--require-all", help="A frame must fire every criterion (AND).")
    ] = False,
    max_frames: Annotated[int, typer.Option("--max-frames", min=1, help="Cap.")] = 50,
    max_per_drive: Annotated[
        int,
        typer.Option(
            "--max-per-drive",
            min=0,
            help="Most frames from one drive, so one bad drive cannot fill the set (0: no cap).",
        ),
    ] = 10,
    min_gap_s: Annotated[
        float, typer.Option("--min-gap-s", min=0.0, help="Least time between picks of a drive.")
    ] = 1.0,
    compare_dir: Annotated[
        Path | None,
        typer.Option("--compare", help="An slt compare output: its spans feed 'span'."),
    ] = None,
    recordings: Annotated[
        list[Path] | None,
        typer.Option("--recordings", help="Folder searched for the runs' recordings."),
    ] = None,
    overwrite: Annotated[bool, overwrite_option()] = False,
) -> None:
    """Pick frames worth labelling and export them with pre-annotations from the fitted lanes.

    Writes images/*.jpg with CULane .lines.txt beside each, labels.json (TuSimple, what
    `slt train --data tusimple=SET` reads) and manifest.parquet (drive, recording, time,
    reasons, scores) under --out. Images are saved at their recorded size and the
    pre-annotations drawn in those pixels (at most 5 lines, nearest the ego lane). Picks are
    spread out: never two of one drive closer than --min-gap-s, at most --max-per-drive of one
    drive, at most --max-frames.
    """
    from superlane_tools.commands.mine.entry import MineOptions, run

    with cli_errors():
        options = MineOptions(
            inputs,
            out,
            criteria,
            require_all,
            max_frames,
            max_per_drive,
            min_gap_s,
            compare_dir,
            recordings or [],
            command_line(),
            new_output(out, overwrite, [*inputs, *(recordings or [])]),
        )
        result = run(options)
    console.print(f"mined {len(result.manifest)} frames -> {out}", markup=False)
    exit_with(report_skipped(result.skipped))


def register(app: typer.Typer) -> None:
    """Add ``slt mine`` to the root app."""
    app.command("mine", help=inspect.cleandoc(mine_cmd.__doc__ or "") + f"\n\n{EXIT_CODES_HELP}")(
        mine_cmd
    )
