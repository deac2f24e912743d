"""`slt segment`: segment images or a recording into leaf-id label PNGs (classical or ONNX)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from superlane_tools.cli._common import (
    EXIT_CODES_HELP,
    camera_option,
    cli_errors,
    model_option,
    note,
    progress,
    report_skipped,
)
from superlane_tools.cli._outputs import new_output, overwrite_option
from superlane_tools.errors import ExitCode


def segment(
    input_path: Annotated[
        Path,
        typer.Argument(
            metavar="INPUT",
            help="Folder of PNG/JPEG images (searched recursively), or a recording (its first "
            "camera topic; labels go to OUT/<topic>/<index>.png).",
        ),
    ],
    out: Annotated[
        Path, typer.Option("--out", help="Output folder for label PNGs and classes.yaml.")
    ],
    backend: Annotated[
        str,
        typer.Option(
            "--backend",
            help="Segmentation backend: auto (the more accurate on real frames, per the model "
            "card), classical or onnx.",
        ),
    ] = "auto",
    model: Annotated[str | None, model_option("ONNX model file or shipped model name.")] = None,
    camera: Annotated[
        str | None,
        camera_option("Camera profile name or YAML file (improves the classical backend)."),
    ] = None,
    overlays: Annotated[
        bool, typer.Option("--overlay", help="Also write colour overlays to OUT/overlays/*.jpg.")
    ] = False,
    overwrite: Annotated[bool, overwrite_option()] = False,
    canonical_camera: Annotated[
        bool,
        typer.Option(
            "--canonical-camera",
            help="Run a network trained without the canonical virtual camera in it too "
            "(needs --camera; a network trained in it always runs in it).",
        ),
    ] = False,
) -> None:
    """Segment images into SUPER hierarchy leaf ids (label PNGs readable by `slt lanes fit`)."""
    from superlane_tools.commands.segment import SegmentParams, run

    guard = new_output(out, overwrite, [input_path])
    params = SegmentParams(
        input_path, out, backend, model, camera, overlays, guard, canonical_camera
    )
    with cli_errors():
        result = run(params, note, lambda total: progress("segment", total, "images"))
    note(
        f"segmented {result.written} of {result.seen} images with the {result.backend} "
        f"backend into {out}"
    )
    code = report_skipped(result.skipped)
    if result.written == 0:
        code = ExitCode.ERROR
    if code != ExitCode.OK:
        raise typer.Exit(int(code))


def register(app: typer.Typer) -> None:
    """Add ``slt segment`` to the root app."""
    app.command("segment", help=f"{segment.__doc__}\n\n{EXIT_CODES_HELP}")(segment)
