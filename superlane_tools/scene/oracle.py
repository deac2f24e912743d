"""Oracle segmentation: ground-truth leaf-id label images by frame index, instead of a network.

``slt simulate --labels`` writes them as ``<frame index:06d>.png``; with them the lane stage is
measured on its own, without segmentation errors.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from superlane_tools.errors import UsageError


class OracleLabels:
    """The label images of a folder, looked up by frame index.

    Args:
        folder: Folder of ``<index:06d>.png`` single-channel leaf-id images.

    Raises:
        UsageError: If the folder does not exist.
    """

    def __init__(self, folder: str | Path) -> None:
        self.folder = Path(folder)
        if not self.folder.is_dir():
            raise UsageError(f"oracle label folder not found: {self.folder}")

    def labels(self, index: int, width: int, height: int) -> NDArray[np.uint8]:
        """Return frame ``index``'s labels at ``width x height`` pixels (nearest-neighbour).

        Raises:
            UsageError: If the image is missing or not single-channel.
        """
        import cv2

        path = self.folder / f"{index:06d}.png"
        read = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
        if read is None or read.ndim != 2:
            raise UsageError(f"oracle label image missing or not single-channel: {path}")
        if read.shape != (height, width):
            read = cv2.resize(read, (width, height), interpolation=cv2.INTER_NEAREST)
        return np.asarray(read, dtype=np.uint8)
