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
from superlane_tools.records import Skipped


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
) -> None:
    """Segment images into SUPER hierarchy leaf ids (label PNGs readable by `slt lanes fit`)."""
    with cli_errors(), new_output(out, overwrite, [input_path]):
        code = _run(input_path, out, backend, model, camera, overlays)
    if code != ExitCode.OK:
        raise typer.Exit(int(code))


def _run(
    input_path: Path,
    out: Path,
    backend_name: str,
    model: str | None,
    camera_name: str | None,
    overlays: bool,
) -> ExitCode:
    from superlane_tools.camera.profiles import load_camera
    from superlane_tools.commands.segment import segment_backend
    from superlane_tools.scene import segment_images
    from superlane_tools.scene.recording_frames import InputFrames

    frames = InputFrames(input_path, out)
    cam = load_camera(camera_name) if camera_name else None
    seg_backend, chosen = segment_backend(input_path, out, backend_name, model, cam)
    for line in chosen:
        note(line)
    skipped: list[Skipped] = []
    written = seen = 0
    with progress("segment", frames.total, "images") as bar:
        for result in segment_images(frames, out, seg_backend, overlays=overlays):
            seen += 1
            if result.skipped is not None:
                skipped.append(result.skipped)
            else:
                written += 1
            bar.advance()
    skipped.extend(frames.skipped)
    note(f"segmented {written} of {seen} images with the {seg_backend.name} backend into {out}")
    if written == 0:
        report_skipped(skipped)
        return ExitCode.ERROR
    return report_skipped(skipped)


def register(app: typer.Typer) -> None:
    """Add ``slt segment`` to the root app."""
    app.command("segment", help=f"{segment.__doc__}\n\n{EXIT_CODES_HELP}")(segment)
