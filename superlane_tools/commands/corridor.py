"""``slt corridor``: ego-corridor probability maps and their table for images or a recording."""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from superlane_tools.records import Progress, Skipped
from superlane_tools.reporting.layout import CORRIDOR_MASKS_TABLE

if TYPE_CHECKING:
    import numpy as np
    from numpy.typing import NDArray

    from superlane_tools.camera.model import CameraModel
    from superlane_tools.corridor import CorridorParams


@dataclass(frozen=True)
class CorridorResult:
    """Outcome of :func:`predict_corridors`.

    Attributes:
        table: The written table (None when no image could be read).
        maps: Probability maps written.
        model: Name of the corridor backend.
        skipped: Images that could not be read.
    """

    table: Path | None
    maps: int
    model: str
    skipped: tuple[Skipped, ...]


def predict_corridors(
    input_path: str | os.PathLike[str],
    out: str | os.PathLike[str],
    model: str | None = None,
    camera_name: str | None = None,
    smooth: int = 3,
    threshold: float = 0.5,
    threads: int = 2,
    command: str = "",
    progress: Progress | None = None,
) -> CorridorResult:
    """Write ``OUT/<name>.png`` (probability x 255) per image and the corridor table.

    Args:
        input_path: Folder of PNG/JPEG images (recursive), or a recording (its first camera).
        out: Output folder.
        model: Corridor ONNX model file or shipped model name (None: the default).
        camera_name: Camera profile or YAML: adds ``width_m`` and ``length_m``.
        smooth: Frames averaged against wiper occlusion (1 = off).
        threshold: Corridor probability cut.
        threads: onnxruntime threads.
        command: Command line for the provenance.
        progress: Called as ``progress(done, total)`` after each image.

    Raises:
        SceneError: For an unusable model or input.
    """
    import pandas as pd

    from superlane_tools.camera.profiles import load_camera
    from superlane_tools.corridor import CorridorParams
    from superlane_tools.reporting import Provenance, input_identity, write_table
    from superlane_tools.scene.corridor_runtime import CorridorSmoother, OnnxCorridorModel
    from superlane_tools.scene.recording_frames import InputFrames

    src, dst = Path(input_path), Path(out)
    cam = load_camera(camera_name) if camera_name else None
    runtime = OnnxCorridorModel(model, threads=threads)
    frames = InputFrames(src, dst)
    smoother = CorridorSmoother(smooth)
    params = CorridorParams(threshold=threshold)
    rows: list[dict[str, object]] = []
    skipped: list[Skipped] = []
    for done, frame in enumerate(frames, start=1):
        if progress is not None:
            progress(done, frames.total)
        image = frame.image
        if image is None or image.shape[0] < 8 or image.shape[1] < 8:
            skipped.append(Skipped("unreadable image", frame.problem or frame.name, 1))
            smoother.reset()
            continue
        prob = smoother.update(runtime.probability(image))
        rows.append(_write_map(prob, dst, frame.name, cam, params))
    skipped.extend(frames.skipped)
    if not rows:
        return CorridorResult(None, 0, runtime.name, tuple(skipped))
    provenance = Provenance(
        command=command,
        inputs=(input_identity(src),),
        config={
            "smooth_frames": smooth,
            "threshold": threshold,
            "camera": cam.name if cam else None,
        },
        models={runtime.card.name: runtime.sha256},
    )
    table = write_table(pd.DataFrame(rows), dst / CORRIDOR_MASKS_TABLE.file, provenance)
    return CorridorResult(table, len(rows), runtime.name, tuple(skipped))


def _write_map(
    prob: NDArray[np.float32],
    dst: Path,
    name: str,
    cam: CameraModel | None,
    params: CorridorParams,
) -> dict[str, object]:
    """Write one image's probability map as ``dst/<name>.png``; return its table row."""
    import cv2
    import numpy as np

    from superlane_tools.corridor import corridor_from_mask
    from superlane_tools.reporting import write_bytes_atomic

    rel = Path(f"{name}.png")
    ok, png = cv2.imencode(".png", np.round(prob * 255.0).astype(np.uint8))
    assert ok, "PNG encoding of a uint8 image cannot fail"
    write_bytes_atomic(dst / rel, png.tobytes())
    geometry = corridor_from_mask(prob, cam, params) if cam is not None else None
    return {
        "name": rel.as_posix(),
        "corridor_fraction": float((prob > params.threshold).mean()),
        "width_m": geometry.width_m if geometry else math.nan,
        "length_m": geometry.length_m if geometry else math.nan,
    }
