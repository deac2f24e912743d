"""Read a folder of class-id label PNGs (``slt segment``'s output): masks, images, times."""

from __future__ import annotations

import csv
import os
import re
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from superlane_tools.scene.errors import SceneError
from superlane_tools.scene.image_folder import TIMES_FILE


def natural_key(rel_path: str) -> tuple[tuple[int, int | str], ...]:
    """Sort key that orders digit runs by value (``clip/2.png`` before ``clip/10.png``)."""
    return tuple(
        (0, int(part)) if part.isdigit() else (1, part)
        for part in re.split(r"(\d+)", rel_path)
        if part
    )


def find_masks(seg_dir: str | os.PathLike[str]) -> list[Path]:
    """Return the PNG files under ``seg_dir`` (recursively), in natural order of relative path.

    Raises:
        SceneError: If ``seg_dir`` is not a folder.
    """
    root = Path(seg_dir)
    if not root.is_dir():
        raise SceneError(f"segmentation folder not found: {root}")
    return sorted(
        (p for p in root.rglob("*") if p.is_file() and p.suffix.lower() == ".png"),
        key=lambda p: natural_key(p.relative_to(root).as_posix()),
    )


def read_mask(path: Path) -> NDArray[Any] | str:
    """Return the mask array, or why it cannot be used."""
    import cv2  # late: heavy import

    mask = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    if mask is None:
        return "unreadable PNG"
    if mask.ndim != 2:
        return f"not a single-channel class-id image (shape {mask.shape})"
    return mask


IMAGE_EXTS = (".jpg", ".jpeg", ".png")
"""Camera image extensions looked up beside a mask's relative path with ``images_dir``."""


def read_camera_image(
    images_dir: Path, rel: Path, size: tuple[int, int]
) -> NDArray[np.uint8] | str:
    """Return the camera image for mask ``rel`` resized to the mask's ``size``, or why not."""
    import cv2  # late: heavy import

    for ext in IMAGE_EXTS:
        candidate = images_dir / rel.with_suffix(ext)
        if candidate.is_file():
            image = cv2.imread(str(candidate), cv2.IMREAD_COLOR)
            if image is None:
                return f"unreadable image {candidate.name}"
            if (image.shape[1], image.shape[0]) != size:
                image = cv2.resize(image, size, interpolation=cv2.INTER_AREA)
            return np.asarray(image, dtype=np.uint8)
    return f"no camera image for it under {images_dir}"


def read_segment_times(seg_dir: Path) -> dict[str, float]:
    """Return ``name -> segmentation ms`` from ``seg_dir/segment_times.csv`` (empty if absent)."""
    path = seg_dir / TIMES_FILE
    if not path.is_file():
        return {}
    out: dict[str, float] = {}
    with path.open(encoding="utf-8", newline="") as handle:
        for row in csv.DictReader(handle):
            try:
                out[row["name"]] = float(row["seg_ms"])
            except (KeyError, TypeError, ValueError):
                continue
    return out
