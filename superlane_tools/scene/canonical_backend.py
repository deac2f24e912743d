"""A segmentation backend seen through the canonical virtual camera (``camera.canonical``).

:class:`CanonicalBackend` wraps a network backend: each frame is resampled into the canonical
camera (undistort, rotate to pitch and roll 0, rescale, crop: one ``cv2.remap``), segmented
there, and the label image is mapped back to the frame's own pixels (nearest-neighbour; pixels
the canonical camera does not see are void). The lane fit, the exports and the overlays
therefore work in the recording's pixels as without the wrapper. The remap tables are computed
once per image size (once per drive: every frame of a drive has one size), not per frame.
"""

from __future__ import annotations

import threading
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

from superlane_tools.camera.canonical import CanonicalCamera, CanonicalMaps, canonical_maps
from superlane_tools.camera.model import CameraModel
from superlane_tools.scene.backend import SegmentationBackend, check_image

if TYPE_CHECKING:
    import numpy as np
    from numpy.typing import NDArray

CARD_KEY = "canonical_camera"
"""Model card ``training`` entry of a model trained in the canonical camera (its mapping)."""


def trained_canonical(card: Any) -> CanonicalCamera | None:
    """Return the canonical camera a model was trained in (its card's), or None."""
    training = getattr(card, "training", None) or {}
    recorded = training.get(CARD_KEY) if isinstance(training, Mapping) else None
    return CanonicalCamera.from_dict(recorded) if isinstance(recorded, Mapping) else None


def canonical_for_card(card: Any) -> CanonicalCamera:
    """Return the canonical camera of a model card: its training's, else its input size's.

    A model trained with ``--canonical-camera`` records its canonical camera in the card
    (``training.canonical_camera``); any other model gets :meth:`CanonicalCamera.for_input` of
    its input size.
    """
    return trained_canonical(card) or CanonicalCamera.for_input(card.input.width, card.input.height)


class CanonicalBackend:
    """Run ``inner`` in the canonical camera; return labels in the frame's own pixels.

    Implements the ``SegmentationBackend`` protocol.

    Args:
        inner: The network backend (it receives canonical images of ``canonical``'s size).
        camera: The drive's camera (resized to each frame's size as needed).
        canonical: The canonical camera (usually :func:`canonical_for_card` of the model).
    """

    def __init__(
        self, inner: SegmentationBackend, camera: CameraModel, canonical: CanonicalCamera
    ) -> None:
        self.inner = inner
        self.camera = camera
        self.canonical = canonical
        self.name = f"{inner.name}+canonical"
        self._maps: dict[tuple[int, int], CanonicalMaps] = {}
        self._lock = threading.Lock()
        self.maps_computed = 0
        """How many remap tables were computed (one per image size: once per drive)."""

    @property
    def sha256(self) -> str:
        """The inner model's SHA-256 ("" for a backend without one), for provenance."""
        return str(getattr(self.inner, "sha256", ""))

    def maps(self, width: int, height: int) -> CanonicalMaps:
        """Return the remap tables of ``width x height`` frames (computed on first use)."""
        key = (width, height)
        with self._lock:  # frames are prepared on a thread pool: compute each table once
            maps = self._maps.get(key)
            if maps is None:
                cam = self.camera
                drive = cam if (cam.width, cam.height) == key else cam.resized(width, height)
                maps = canonical_maps(drive, self.canonical)
                self._maps[key] = maps
                self.maps_computed += 1
        return maps

    def segment(self, image_bgr: NDArray[np.uint8]) -> NDArray[np.uint8]:
        """Return the ``(H, W)`` leaf-id image of one BGR frame, in the frame's pixels."""
        image = check_image(image_bgr)
        maps = self.maps(image.shape[1], image.shape[0])
        labels = self.inner.segment(maps.to_canonical(image))
        return maps.labels_to_source(labels)

    def segment_batch(self, images_bgr: Sequence[NDArray[np.uint8]]) -> list[NDArray[np.uint8]]:
        """Return the leaf-id images of several frames."""
        return [self.segment(image) for image in images_bgr]
