"""Read label images as stored ids: palette PNGs through Pillow (indices), others through OpenCV.

Mapillary Vistas (and many other datasets) store labels as 8-bit palette PNGs. OpenCV expands a
palette image to its colours, so id 13 comes back as the colour of entry 13; Pillow returns the
palette *indices*, which are the ids.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from superlane_tools.training.errors import TrainingError


def read_label_ids(path: str | os.PathLike[str]) -> NDArray[np.uint8]:
    """Return the ``(H, W)`` ``uint8`` label ids stored in a label image.

    Palette (``P``) and grayscale (``L``) images give their stored values; colour label images
    give their first channel in OpenCV's BGR order (the blue channel, as before).

    Raises:
        TrainingError: If the file cannot be read or holds ids above 255.
    """
    from PIL import Image, UnidentifiedImageError

    source = Path(path)
    try:
        with Image.open(source) as image:
            mode = image.mode
            array = np.asarray(image)
    except (OSError, UnidentifiedImageError) as err:
        raise TrainingError(f"cannot read label image {source}: {err}") from err
    if mode in {"P", "L", "1"}:
        return np.asarray(array, dtype=np.uint8)
    if array.ndim == 3:
        # colour label image: Pillow gives RGB(A); OpenCV's channel 0 (blue) is index 2
        return np.ascontiguousarray(array[:, :, 2], dtype=np.uint8)
    if array.size and int(array.max()) > 255:
        raise TrainingError(f"{source}: label ids above 255 are not supported")
    return np.asarray(array, dtype=np.uint8)
