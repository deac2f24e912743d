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
    note,
    progress,
    report_skipped,
)
from superlane_tools.errors import ExitCode
from superlane_tools.records import Skipped


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
        typer.Option("--model", help="Corridor ONNX model file or shipped model name."),
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
) -> None:
    """Predict the ego corridor (ego lane up to the preceding vehicle) of every image.

    Writes OUT/<name>.png (probability x 255, uint8, the image's size, averaged over the last
    --smooth frames in name order) and OUT/corridor.parquet (name, area fraction, and width_m /
    length_m through the camera model when --camera is given).
    """
    with cli_errors():
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
    import math

    import cv2
    import numpy as np
    import pandas as pd

    from superlane_tools.camera.profiles import load_camera
    from superlane_tools.corridor.geometry import CorridorParams, corridor_from_mask
    from superlane_tools.reporting import (
        Provenance,
        input_identity,
        write_bytes_atomic,
        write_table,
    )
    from superlane_tools.scene.corridor_runtime import CorridorSmoother, OnnxCorridorModel
    from superlane_tools.scene.recording_frames import InputFrames

    cam = load_camera(camera_name) if camera_name else None
    runtime = OnnxCorridorModel(model, threads=threads)
    frames = InputFrames(input_path, out)
    smoother = CorridorSmoother(smooth)
    params = CorridorParams(threshold=threshold)
    rows: list[dict[str, object]] = []
    skipped: list[Skipped] = []
    with progress("corridor", frames.total, "images") as bar:
        for frame in frames:
            bar.advance()
            image = frame.image
            if image is None or image.shape[0] < 8 or image.shape[1] < 8:
                skipped.append(Skipped("unreadable image", frame.problem or frame.name, 1))
                smoother.reset()
                continue
            prob = smoother.update(runtime.probability(image))
            rel = Path(f"{frame.name}.png")
            ok, png = cv2.imencode(".png", np.round(prob * 255.0).astype(np.uint8))
            assert ok, "PNG encoding of a uint8 image cannot fail"
            write_bytes_atomic(out / rel, png.tobytes())
            geometry = corridor_from_mask(prob, cam, params) if cam is not None else None
            rows.append(
                {
                    "name": rel.as_posix(),
                    "corridor_fraction": float((prob > threshold).mean()),
                    "width_m": geometry.width_m if geometry else math.nan,
                    "length_m": geometry.length_m if geometry else math.nan,
                }
            )
    skipped.extend(frames.skipped)
    if not rows:
        report_skipped(skipped)
        return ExitCode.ERROR
    provenance = Provenance(
        command=command_line(),
        inputs=(input_identity(input_path),),
        config={
            "smooth_frames": smooth,
            "threshold": threshold,
            "camera": cam.name if cam else None,
        },
        models={runtime.card.name: runtime.sha256},
    )
    write_table(pd.DataFrame(rows), out / "corridor.parquet", provenance)
    note(f"wrote {len(rows)} corridor maps with {runtime.name} into {out}")
    return report_skipped(skipped)


def register(app: typer.Typer) -> None:
    """Add ``slt corridor`` to the root app."""
    doc = inspect.cleandoc(corridor.__doc__ or "")
    app.command("corridor", help=f"{doc}\n\n{EXIT_CODES_HELP}")(corridor)
