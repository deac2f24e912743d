"""``slt segment``'s backend: ``auto`` on an image folder runs the per-drive self-check first."""

from __future__ import annotations

from pathlib import Path

from superlane_tools.camera.model import CameraModel
from superlane_tools.scene.backend import SegmentationBackend


def segment_backend(
    input_path: Path, out: Path, backend: str, model: str | None, camera: CameraModel | None
) -> tuple[SegmentationBackend, list[str]]:
    """Return the backend ``slt segment`` uses and the lines that say how it was chosen.

    ``auto`` without ``--model`` on an image folder with a camera tries each candidate backend
    on a sample of the images (:func:`~superlane_tools.drive.selfcheck.images_self_check`) and
    uses the most plausible; otherwise the lines say why the self-check did not run.

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
        from superlane_tools.drive.selfcheck import images_self_check
        from superlane_tools.reporting.drive_notes import unlike_training_data

        check = images_self_check(list_images(input_path, exclude=out), camera)
        lines = check.lines()
        if not check.plausible:
            lines.append(unlike_training_data(check.reason))
        return backend_from_name(check.backend, model=check.model or None, camera=camera), lines
    return backend_from_name(backend, model=model, camera=camera), lines
