"""The segmentation backend protocol and the factory that builds a backend by name."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray

from superlane_tools.scene.errors import SceneError

ImageBGR = NDArray[np.uint8]
LabelImage = NDArray[np.uint8]


@runtime_checkable
class SegmentationBackend(Protocol):
    """Anything that turns a BGR image into a leaf-id label image.

    Label images store :mod:`superlane_tools.hierarchy` leaf ids (``uint8``, 0 = void) at the
    input resolution, so every backend (classical, ONNX, a user's own) is interchangeable.

    """

    @property
    def name(self) -> str:
        """Short backend name, recorded in outputs for provenance."""
        ...

    def segment(self, image_bgr: ImageBGR) -> LabelImage:
        """Return the ``(H, W)`` uint8 leaf-id image of one ``(H, W, 3)`` uint8 BGR image."""
        ...

    def segment_batch(self, images_bgr: Sequence[ImageBGR]) -> list[LabelImage]:
        """Return the label images of several BGR images (backends may batch internally)."""
        ...


def check_image(image_bgr: object) -> ImageBGR:
    """Return ``image_bgr`` if it is an ``(H, W, 3)`` uint8 array, else raise.

    Raises:
        SceneError: If the array has the wrong shape or dtype.
    """
    if not isinstance(image_bgr, np.ndarray):
        raise SceneError(f"expected a numpy image, got {type(image_bgr).__name__}")
    if image_bgr.dtype != np.uint8 or image_bgr.ndim != 3 or image_bgr.shape[2] != 3:
        raise SceneError(
            f"expected an (H, W, 3) uint8 BGR image, got {image_bgr.shape} {image_bgr.dtype}"
        )
    if image_bgr.shape[0] < 8 or image_bgr.shape[1] < 8:
        raise SceneError(f"image too small to segment: {image_bgr.shape[1]}x{image_bgr.shape[0]}")
    return image_bgr
