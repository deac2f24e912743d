"""`slt lanes`: fit the SUPER multi-lane model to segmentation masks; export TuSimple JSON."""

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
    progress,
    report_skipped,
)
from superlane_tools.cli._outputs import check_new_output, new_output, overwrite_option

lanes_app = typer.Typer(
    name="lanes",
    help=f"Multi-lane fit (SUPER paper section III) and TuSimple export.\n\n{EXIT_CODES_HELP}",
    no_args_is_help=True,
    rich_markup_mode=None,
)


@lanes_app.command("fit")
def fit_cmd(
    seg_dir: Annotated[
        Path, typer.Argument(help="Folder of class-id PNG masks (searched recursively).")
    ],
    camera: Annotated[str, camera_option("Camera profile name or camera YAML file.")],
    out: Annotated[Path, typer.Option(help="Output Parquet file (one row per mask).")],
    classes: Annotated[
        Path | None,
        typer.Option(
            help="YAML mapping class nodes to mask ids [default: SEG_DIR/classes.yaml].",
            exists=True,
            dir_okay=False,
        ),
    ] = None,
    sequential: Annotated[
        bool,
        typer.Option(
            help="Warm-start each frame from the previous one in the same folder (a clip); "
            "masks are taken in natural order (2 before 10)."
        ),
    ] = False,
    no_slope: Annotated[
        bool, typer.Option("--no-slope", help="Fit a flat road (no slope compensation).")
    ] = False,
    images: Annotated[
        Path | None,
        typer.Option(
            help="Folder of the camera images (same relative paths as the masks): lane colour "
            "is read from the image when the masks have no level-4 marking classes.",
            exists=True,
            file_okay=False,
        ),
    ] = None,
    overwrite: Annotated[bool, overwrite_option()] = False,
) -> None:
    """Fit lanes, heading, curvature and road slope to every mask under SEG_DIR."""
    from superlane_tools.commands.lanes.entry import FitOptions, fit

    with cli_errors():
        check_new_output(out, overwrite, [seg_dir])
        options = FitOptions(
            seg_dir,
            camera,
            out,
            classes,
            sequential,
            not no_slope,
            images,
            command_line(),
            new_output(out, overwrite, [seg_dir]),
        )
        result = fit(options, lambda: progress("fitting lanes", unit="masks"))
        note(f"fitted {result.n_fitted} of {result.n_frames} frames -> {result.out}")
    exit_with(report_skipped(result.skipped))


@lanes_app.command("export-tusimple")
def export_cmd(
    lanes_parquet: Annotated[Path, typer.Argument(help="lanes.parquet from `slt lanes fit`.")],
    camera: Annotated[str, camera_option("Camera profile name or camera YAML file.")],
    out: Annotated[Path, typer.Option(help="Output TuSimple JSON-lines file.")],
    h_samples: Annotated[
        str,
        typer.Option(help="Image rows START:STOP:STEP (stop exclusive), used without --tasks."),
    ] = "160:720:10",
    tasks: Annotated[
        Path | None,
        typer.Option(
            help="TuSimple task or label file (test_tasks.json, label_data_*.json): each frame "
            "is sampled at the h_samples of the entry with its raw_file."
        ),
    ] = None,
    max_lines: Annotated[
        int,
        typer.Option(
            help="Most lines per frame, nearest the camera first (LaneEval zeroes a frame with "
            "more than n_gt + 2)."
        ),
    ] = 5,
    lanes: Annotated[
        int | None,
        typer.Option(
            "--lanes",
            help="Known number of lanes (e.g. from a map): keep the N+1 adjacent lines with the "
            "most support.",
        ),
    ] = None,
    raw_ext: Annotated[
        str, typer.Option(help="Extension that replaces the mask's in raw_file.")
    ] = ".jpg",
    overwrite: Annotated[bool, overwrite_option()] = False,
) -> None:
    """Project fitted lanes into the image at each frame's rows; write TuSimple JSON lines."""
    from superlane_tools.commands.lanes.entry import TusimpleOptions, tusimple

    with cli_errors():
        check_new_output(out, overwrite, [lanes_parquet])
        guard = new_output(out, overwrite, [lanes_parquet])
        options = TusimpleOptions(
            lanes_parquet, camera, out, h_samples, tasks, max_lines, lanes, raw_ext, guard
        )
        result = tusimple(options)
        note(f"wrote {result.n_records} frames -> {result.out}")


@lanes_app.command("export-kitti")
def export_kitti_cmd(
    lanes_parquet: Annotated[Path, typer.Argument(help="lanes.parquet from `slt lanes fit`.")],
    camera: Annotated[str, camera_option("Camera profile name or camera YAML file.")],
    out: Annotated[Path, typer.Option(help="Output folder of KITTI ego-lane PNGs.")],
    overwrite: Annotated[bool, overwrite_option()] = False,
) -> None:
    """Rasterise each frame's fitted ego lane as a KITTI submission PNG (um_lane_NNNNNN.png)."""
    from superlane_tools.commands.lanes.entry import kitti

    with cli_errors():
        check_new_output(out, overwrite, [lanes_parquet])
        result = kitti(lanes_parquet, camera, out, new_output(out, overwrite, [lanes_parquet]))
        note(f"wrote {result.n_records} frames -> {result.out}")


def register(app: typer.Typer) -> None:
    """Add the ``lanes`` command group to the root app."""
    app.add_typer(lanes_app)
