"""`slt reprocess`: a drive in, every table, plot, report and Foxglove annotation out."""

from __future__ import annotations

import inspect
from pathlib import Path
from typing import Annotated

import typer

from superlane_tools.cli._common import (
    EXIT_CODES_HELP,
    camera_option,
    check_dbc_specs,
    cli_errors,
    command_line,
    console,
    exit_with,
    model_option,
    note,
    progress,
    report_skipped,
)
from superlane_tools.cli._outputs import check_new_output, new_output, overwrite_option


def _recording_name(path: Path) -> str:
    return path.name.split(".")[0] if path.suffix else path.name


# The options, as Typer reads them from the annotations.
_Recording = Annotated[
    Path | None,
    typer.Argument(
        help="Recording: MCAP, ROS 1 .bag, ROS 2 bag folder, or a dashcam video (.mp4, .mkv)."
    ),
]
_Out = Annotated[
    Path | None, typer.Option("--out", "-o", help="Output folder (default runs/<name>/).")
]
_Config = Annotated[
    Path | None,
    typer.Option("--config", help="Config file (.toml or .yaml).", exists=True, dir_okay=False),
]
_PrintConfig = Annotated[
    bool, typer.Option("--print-config", help="Print the default config (YAML) and exit.")
]
_Camera = Annotated[
    str | None,
    camera_option("'auto' (CameraInfo + extrinsics), a profile or a YAML.", "auto|NAME|YAML"),
]
_Dbc = Annotated[
    list[Path] | None,
    typer.Option(
        "--dbc",
        metavar="[BUS=]FILE",
        help="DBC file (repeatable; replaces the shipped DBCs); BUS=FILE binds it to one "
        "CAN bus (topic), e.g. can0=pt.dbc.",
        callback=check_dbc_specs,
    ),
]
_Backend = Annotated[
    str | None,
    typer.Option("--backend", help="Segmentation: auto, classical, onnx or oracle."),
]
_Model = Annotated[str | None, model_option("Segmentation ONNX model (path or name).")]
_OracleLabels = Annotated[
    Path | None,
    typer.Option(
        "--oracle-labels",
        help="Leaf-id label PNG folder for --backend oracle.",
        exists=True,
        file_okay=False,
    ),
]
_Category = Annotated[
    str | None, typer.Option("--category", help="Category label of this drive's sequences.")
]
_Video = Annotated[bool, typer.Option("--video", help="Also write overlay.mp4.")]
_NoPlots = Annotated[bool, typer.Option("--no-plots", help="Skip plots/*.png.")]
_Workers = Annotated[int | None, typer.Option("--workers", help="Threads for the image stages.")]
_WithSignals = Annotated[
    bool,
    typer.Option(
        "--with-signals",
        help="Add decoded CAN signals and the truth curves to annotations.mcap.",
    ),
]
_CanonicalCamera = Annotated[
    bool | None,
    typer.Option(
        "--canonical-camera/--no-canonical-camera",
        help="Segment in the canonical virtual camera also with models trained without "
        "it (network backends; default off; models trained in it always use it).",
    ),
]
_Overwrite = Annotated[bool, overwrite_option()]


def reprocess_cmd(
    recording: _Recording = None,
    out: _Out = None,
    config: _Config = None,
    print_config: _PrintConfig = False,
    camera: _Camera = None,
    dbc: _Dbc = None,
    backend: _Backend = None,
    model: _Model = None,
    oracle_labels: _OracleLabels = None,
    category: _Category = None,
    video: _Video = False,
    no_plots: _NoPlots = False,
    workers: _Workers = None,
    with_signals: _WithSignals = False,
    canonical_camera: _CanonicalCamera = None,
    overwrite: _Overwrite = False,
) -> None:
    """Reprocess a drive: SUPER lane fit, corridor network, Hough baseline, CAN, RTK.

    Writes frames/lanes/corridor/baseline/availability/curvature/mobileye/rtk/can_signals
    Parquet tables, plots/*.png, report.md, report.html and annotations.mcap under --out.
    Options override the config file. Missing streams degrade gracefully and are stated in
    the report; exit code 3 means input data was lost.
    """
    from superlane_tools.errors import UsageError

    if print_config:
        from superlane_tools.commands.reprocess.entry import default_config

        typer.echo(default_config(), nl=False)
        return
    with cli_errors():
        if recording is None:
            raise UsageError("missing argument RECORDING (or use --print-config)")
        target = out if out is not None else Path("runs") / _recording_name(recording)
        check_new_output(target, overwrite, [recording])
        from superlane_tools.commands.reprocess.entry import ReprocessOptions, run

        options = ReprocessOptions(
            recording,
            target,
            config,
            camera,
            dbc or [],
            backend,
            model,
            oracle_labels,
            category,
            video,
            not no_plots,
            workers,
            with_signals,
            canonical_camera,
            command_line(),
            new_output(target, overwrite, [recording], replaces=True),
        )
        outcome = run(options, lambda: progress("reprocess", unit="frames"))
        result = outcome.result
        if outcome.signals_line is not None:
            console.print(outcome.signals_line, markup=False)
    for line in result.notes:  # with the "Lanes not plausible" warning when there is one
        note(line)
    code = report_skipped(result.skipped)
    console.print(f"reprocessed {result.frames} frames -> {target}", markup=False)
    console.print(outcome.times_line, markup=False)
    console.print(outcome.report_line, markup=False)
    exit_with(code)


def register(app: typer.Typer) -> None:
    """Add this module's commands to the root app."""
    app.command(
        "reprocess",
        help=inspect.cleandoc(reprocess_cmd.__doc__ or "") + f"\n\n{EXIT_CODES_HELP}",
    )(reprocess_cmd)
