"""Segment images (a folder, or frames from elsewhere): label PNGs, overlays, ``classes.yaml``.

Output layout under ``out_dir``:

* ``<relative path>.png``: leaf-id label image (``uint8``, 0 = void) for each input image, at the
  input's relative path with the suffix replaced by ``.png``;
* ``overlays/<relative path>.jpg`` (optional): the colourised labels blended over the image;
* ``classes.yaml``: every hierarchy node name with the leaf ids under it, so that
  ``slt lanes fit DIR --classes DIR/classes.yaml`` can find road and lane-marking pixels;
* ``segment_times.csv``: ``name,seg_ms`` per segmented frame (the backend call's wall time,
  milliseconds), read by ``slt lanes fit`` so that a TuSimple ``run_time`` covers both stages.

All files are written atomically.
"""

from __future__ import annotations

import csv
import io
import time
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from superlane_tools.hierarchy import NODES, colorize, leaf_ids_under
from superlane_tools.records import Skipped
from superlane_tools.reporting.atomic import write_bytes_atomic, write_text_atomic
from superlane_tools.scene.backend import SegmentationBackend
from superlane_tools.scene.errors import SceneError

IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg")
OVERLAY_DIR = "overlays"
CLASSES_FILE = "classes.yaml"
TIMES_FILE = "segment_times.csv"


class InputFrame(NamedTuple):
    """One image to process, from a folder or a recording.

    Attributes:
        name: Output name relative to the output folder, without suffix (``sub/img`` for
            ``sub/img.jpg``; ``<topic>/<index:06d>`` for recording frames).
        image: ``(H, W, 3)`` uint8 BGR image, or None when it could not be read.
        problem: Why the image could not be read (empty when it could).
        log_time_ns: Log time of a recording frame, ns since the epoch (None for files).
    """

    name: str
    image: NDArray[np.uint8] | None
    problem: str = ""
    log_time_ns: int | None = None


class SegmentedImage(NamedTuple):
    """What happened to one input image.

    Attributes:
        source: Input image path.
        labels_path: Written label PNG, or None when the image was skipped.
        skipped: The skip record when the image could not be read, else None.
    """

    source: Path
    labels_path: Path | None
    skipped: Skipped | None


def list_images(folder: Path, exclude: Path | None = None) -> list[Path]:
    """Return the PNG/JPEG files under ``folder`` (recursive), sorted by relative path.

    Args:
        folder: Input folder.
        exclude: A folder whose contents are ignored (the output folder, when it is inside).
    """
    found = []
    for path in folder.rglob("*"):
        if not path.is_file() or path.suffix.lower() not in IMAGE_SUFFIXES:
            continue
        if exclude is not None and path.resolve().is_relative_to(exclude.resolve()):
            continue
        found.append(path)
    return sorted(found, key=lambda p: p.relative_to(folder).as_posix())


def classes_yaml(backend_name: str) -> str:
    """Return the ``classes.yaml`` text: each hierarchy node name -> its leaf ids."""
    lines = [
        "# Leaf ids of every SUPER hierarchy node in the label PNGs of this folder (0 = void).",
        f"# Written by slt segment (backend: {backend_name}).",
    ]
    for node in NODES:
        ids = ", ".join(str(i) for i in leaf_ids_under(node.name))
        lines.append(f"{node.name}: [{ids}]")
    return "\n".join(lines) + "\n"


def overlay(image_bgr: NDArray[np.uint8], labels: NDArray[np.uint8]) -> NDArray[np.uint8]:
    """Return the colourised labels blended 50/50 over the image (void pixels untouched)."""
    colour = colorize(labels)
    blend = ((image_bgr.astype(np.uint16) + colour) // 2).astype(np.uint8)
    out: NDArray[np.uint8] = np.where((labels > 0)[:, :, None], blend, image_bgr)
    return out


def _encode(suffix: str, image: NDArray[np.uint8]) -> bytes:
    import cv2  # late: heavy import

    ok, buf = cv2.imencode(suffix, image)
    if not ok:
        raise SceneError(f"cannot encode a {image.shape} image as {suffix}")
    return bytes(buf.tobytes())


def segment_folder(
    folder: Path,
    out_dir: Path,
    backend: SegmentationBackend,
    *,
    overlays: bool = False,
    images: list[Path] | None = None,
) -> Iterator[SegmentedImage]:
    """Segment every image under ``folder`` into ``out_dir``; yield one record per image.

    ``classes.yaml`` is written first. Unreadable images are yielded with a :class:`Skipped`
    record and produce no output.

    Args:
        folder: Input folder.
        out_dir: Output folder (created).
        backend: Segmentation backend.
        overlays: Also write ``overlays/<relative path>.jpg``.
        images: The images to process (default: :func:`list_images` of ``folder``).
    """
    todo = images if images is not None else list_images(folder, exclude=out_dir)
    yield from segment_images(folder_frames(folder, todo), out_dir, backend, overlays=overlays)


def folder_frames(folder: Path, images: Iterable[Path]) -> Iterator[InputFrame]:
    """Read ``images`` (paths under ``folder``) as :class:`InputFrame` records, in order."""
    import cv2  # late: heavy import

    for path in images:
        name = path.relative_to(folder).with_suffix("").as_posix()
        try:
            data = np.fromfile(path, dtype=np.uint8)
        except OSError as err:
            yield InputFrame(name, None, f"{path}: {err.strerror}")
            continue
        decoded = cv2.imdecode(data, cv2.IMREAD_COLOR) if data.size else None
        if decoded is None:
            yield InputFrame(name, None, f"{path}: not an image")
            continue
        yield InputFrame(name, np.asarray(decoded, dtype=np.uint8))


def segment_images(
    frames: Iterable[InputFrame],
    out_dir: Path,
    backend: SegmentationBackend,
    *,
    overlays: bool = False,
) -> Iterator[SegmentedImage]:
    """Segment ``frames`` into ``out_dir`` (``<name>.png``); yield one record per frame.

    ``classes.yaml`` is written first; frames that could not be read yield a :class:`Skipped`
    record and produce no output.
    """
    write_text_atomic(out_dir / CLASSES_FILE, classes_yaml(backend.name))
    times = io.StringIO()
    table = csv.writer(times, lineterminator="\n")
    table.writerow(["name", "seg_ms"])
    for frame in frames:
        source = Path(frame.name)
        if frame.image is None:
            yield SegmentedImage(source, None, Skipped("unreadable image", frame.problem))
            continue
        start = time.perf_counter()
        labels = backend.segment(frame.image)
        table.writerow([frame.name, f"{(time.perf_counter() - start) * 1e3:.3f}"])
        target = out_dir / f"{frame.name}.png"
        write_bytes_atomic(target, _encode(".png", labels))
        if overlays:
            view = overlay(frame.image, labels)
            write_bytes_atomic(out_dir / OVERLAY_DIR / f"{frame.name}.jpg", _encode(".jpg", view))
        yield SegmentedImage(source, target, None)
    write_text_atomic(out_dir / TIMES_FILE, times.getvalue())
