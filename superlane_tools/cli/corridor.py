"""`slt corridor`: ego-corridor probability PNGs and corridor.parquet for an image folder."""

from __future__ import annotations

import inspect
from pathlib import Path
from typing import Annotated

import typer

from superlane_tools.cli._common import (
    EXIT_CODES_HELP,
    camera_option,
    cli_errors,
    command_line,
    model_option,
    note,
    progress,
    report_skipped,
)
from superlane_tools.cli._outputs import new_output, overwrite_option
from superlane_tools.errors import ExitCode


def corridor(
    input_path: Annotated[
        Path,
        typer.Argument(
            metavar="INPUT",
            help="Folder of PNG/JPEG images (searched recursively), or a recording (its first "
            "camera topic; maps go to OUT/<topic>/<index>.png).",
        ),
    ],
    out: Annotated[
        Path, typer.Option("--out", help="Output folder for probability PNGs and corridor.parquet.")
    ],
    model: Annotated[
        str | None,
        model_option("Corridor ONNX model file or shipped model name."),
    ] = None,
    camera: Annotated[
        str | None,
        camera_option("Camera profile name or YAML: adds width_m and length_m."),
    ] = None,
    smooth: Annotated[
        int,
        typer.Option("--smooth", min=1, help="Frames averaged against wiper occlusion (1 = off)."),
    ] = 3,
    threshold: Annotated[
        float, typer.Option("--threshold", min=0.0, max=1.0, help="Corridor probability cut.")
    ] = 0.5,
    threads: Annotated[int, typer.Option("--threads", min=1, help="onnxruntime threads.")] = 2,
    overwrite: Annotated[bool, overwrite_option()] = False,
) -> None:
    """Predict the ego corridor (ego lane up to the preceding vehicle) of every image.

    Writes OUT/<name>.png (probability x 255, uint8, the image's size, averaged over the last
    --smooth frames in name order) and OUT/corridor.parquet (name, area fraction, and width_m /
    length_m through the camera model when --camera is given).
    """
    with cli_errors(), new_output(out, overwrite, [input_path]):
        code = _run(input_path, out, model, camera, smooth, threshold, threads)
    if code != ExitCode.OK:
        raise typer.Exit(int(code))


def _run(
    input_path: Path,
    out: Path,
    model: str | None,
    camera_name: str | None,
    smooth: int,
    threshold: float,
    threads: int,
) -> ExitCode:
    from superlane_tools.commands.corridor import predict_corridors

    with progress("corridor", None, "images") as bar:
        result = predict_corridors(
            input_path,
            out,
            model,
            camera_name,
            smooth,
            threshold,
            threads,
            command=command_line(),
            progress=bar.update,
        )
    if result.table is None:
        report_skipped(result.skipped)
        return ExitCode.ERROR
    note(f"wrote {result.maps} corridor maps with {result.model} into {out}")
    return report_skipped(result.skipped)


def register(app: typer.Typer) -> None:
    """Add ``slt corridor`` to the root app."""
    doc = inspect.cleandoc(corridor.__doc__ or "")
    app.command("corridor", help=f"{doc}\n\n{EXIT_CODES_HELP}")(corridor)
