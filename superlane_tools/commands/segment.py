"""``slt segment``: label PNGs for images; ``auto`` on an image folder runs the self-check first."""

from __future__ import annotations

from collections.abc import Callable
from contextlib import AbstractContextManager, nullcontext
from dataclasses import dataclass, field
from pathlib import Path

from superlane_tools.camera.model import CameraModel
from superlane_tools.commands.options import OutputGuard, ProgressBar
from superlane_tools.records import Skipped
from superlane_tools.scene.backend import SegmentationBackend


@dataclass(frozen=True)
class SegmentParams:
    """What ``slt segment`` was asked.

    Attributes:
        input_path: A folder of images, or a recording (its first camera topic).
        out: The output folder for the label PNGs.
        backend: ``auto``, ``classical`` or ``onnx``.
        model: An ONNX model file or shipped model name, or None.
        camera: A camera profile name or YAML, or None.
        overlays: Also write colour overlays.
        canonical_camera: Run a network trained without the canonical camera in it too
            (needs ``camera``; ``scene.canonical_backend``).
        output_guard: Entered around all the work (the cli's policy for an existing output).
    """

    input_path: Path
    out: Path
    backend: str = "auto"
    model: str | None = None
    camera: str | None = None
    overlays: bool = False
    output_guard: OutputGuard = field(default_factory=nullcontext)
    canonical_camera: bool = False


@dataclass(frozen=True)
class SegmentResult:
    """What was segmented: images written and seen, the backend's name, what was skipped."""

    written: int
    seen: int
    backend: str
    skipped: list[Skipped]


def run(
    params: SegmentParams,
    note: Callable[[str], None],
    progress: Callable[[int | None], AbstractContextManager[ProgressBar]],
) -> SegmentResult:
    """Choose the backend (its reasons go to ``note``), then segment every image.

    Args:
        params: What to segment and how.
        note: Prints one line that says how the backend was chosen.
        progress: Opens the progress display, given the number of images when known.
    """
    from superlane_tools.camera.profiles import load_camera
    from superlane_tools.scene import segment_images
    from superlane_tools.scene.recording_frames import InputFrames

    p = params
    with p.output_guard:
        frames = InputFrames(p.input_path, p.out)
        cam = load_camera(p.camera) if p.camera else None
        seg_backend, chosen = segment_backend(
            p.input_path, p.out, p.backend, p.model, cam, p.canonical_camera
        )
        for line in chosen:
            note(line)
        skipped: list[Skipped] = []
        written = seen = 0
        with progress(frames.total) as bar:
            for result in segment_images(frames, p.out, seg_backend, overlays=p.overlays):
                seen += 1
                if result.skipped is not None:
                    skipped.append(result.skipped)
                else:
                    written += 1
                bar.update(seen)
        skipped.extend(frames.skipped)
    return SegmentResult(written, seen, seg_backend.name, skipped)


def segment_backend(
    input_path: Path,
    out: Path,
    backend: str,
    model: str | None,
    camera: CameraModel | None,
    canonical: bool = False,
) -> tuple[SegmentationBackend, list[str]]:
    """Return the backend ``slt segment`` uses and the lines that say how it was chosen.

    ``auto`` without ``--model`` on an image folder with a camera tries each candidate backend
    on a sample of the images (:func:`~superlane_tools.drive.selfcheck.images_self_check`, with
    ``canonical`` as ``segmentation.canonical_camera``) and uses the most plausible; otherwise
    the lines say why the self-check did not run.

    Raises:
        BackendUnavailableError: If the chosen backend cannot run here.
    """
    from superlane_tools.scene import backend_from_name
    from superlane_tools.scene.image_folder import list_images
    from superlane_tools.scene.recording_frames import is_image_folder

    skipped = "segmentation self-check skipped: "
    if backend.strip().lower() != "auto" or model:
        chosen = f"--model {model}" if model else f"--backend {backend}"
        lines = [f"{skipped}backend chosen explicitly ({chosen})"]
    elif camera is None:
        lines = [f"{skipped}it fits lanes in metres and needs the camera (--camera)"]
    elif not is_image_folder(input_path):
        lines = [f"{skipped}`slt reprocess` runs it on a recording"]
    else:
        from superlane_tools.drive.config import ReprocessConfig
        from superlane_tools.drive.selfcheck import images_self_check
        from superlane_tools.reporting.drive_notes import unlike_training_data

        config = ReprocessConfig().with_overrides({"segmentation.canonical_camera": canonical})
        check = images_self_check(list_images(input_path, exclude=out), camera, config)
        lines = check.lines()
        if not check.plausible:
            lines.append(unlike_training_data(check.reason))
        picked = backend_from_name(
            check.backend, model=check.model or None, camera=camera, canonical=canonical
        )
        return picked, lines
    return backend_from_name(backend, model=model, camera=camera, canonical=canonical), lines
