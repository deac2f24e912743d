"""The segmentation backend protocol and the factory that builds a backend by name."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Protocol, runtime_checkable

import numpy as np
from numpy.typing import NDArray

from superlane_tools.camera.model import CameraModel
from superlane_tools.scene.errors import BackendUnavailableError, SceneError

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


BackendFactory = Callable[[str | None, CameraModel | None], SegmentationBackend]


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


def _classical(model: str | None, camera: CameraModel | None) -> SegmentationBackend:
    from superlane_tools.scene.classical import ClassicalExtractor

    if model:
        raise BackendUnavailableError(
            "the classical backend takes no model; drop --model or use --backend onnx"
        )
    return ClassicalExtractor(camera=camera)


def _onnx(model: str | None, camera: CameraModel | None) -> SegmentationBackend:
    del camera  # the network works in the image; its card fixes the input size
    from superlane_tools.scene.onnx_backend import OnnxSegmentationBackend

    return OnnxSegmentationBackend(model)


REAL_METRIC = "tusimple_val_end_to_end"
"""Card metrics section with the end-to-end LaneEval accuracy on real validation frames."""


def auto_choice(model: str | None = None) -> tuple[str, str]:
    """Return ``(backend name, reason)`` of the ``auto`` backend.

    ``auto`` uses the shipped segmentation model when its card says it is at least as accurate
    end to end on real validation frames (official LaneEval, :data:`REAL_METRIC`) as the
    classical backend measured in the same run, and the classical backend otherwise (or when
    no model is shipped). A given ``model`` always means ONNX.
    """
    if model:
        return "onnx", "a model was given"
    from superlane_tools.models import list_models
    from superlane_tools.scene.model_card import card_path_for, load_card
    from superlane_tools.scene.onnx_backend import DEFAULT_SEGMENTATION_MODEL, resolve_model

    if DEFAULT_SEGMENTATION_MODEL not in list_models():
        return "classical", f"no shipped model {DEFAULT_SEGMENTATION_MODEL}"
    card = load_card(card_path_for(resolve_model(DEFAULT_SEGMENTATION_MODEL)[0]))
    real = card.metrics.get(REAL_METRIC) or {}
    acc, classical = real.get("laneeval_accuracy"), real.get("classical_laneeval_accuracy")
    if acc is None or classical is None:
        return "classical", f"{card.name} has no real-frame accuracy in its card"
    if float(acc) >= float(classical):
        return "onnx", f"{card.name}: LaneEval {acc:.3f} >= classical {classical:.3f} (real frames)"
    return "classical", f"classical: LaneEval {classical:.3f} > {card.name} {acc:.3f} (real frames)"


def _auto(model: str | None, camera: CameraModel | None) -> SegmentationBackend:
    name, _ = auto_choice(model)
    return _FACTORIES[name](model, camera)


_FACTORIES: dict[str, BackendFactory] = {"auto": _auto, "classical": _classical, "onnx": _onnx}


def known_backends() -> tuple[str, ...]:
    """Return the names accepted by :func:`backend_from_name`, sorted."""
    return tuple(sorted(_FACTORIES))


def backend_from_name(
    name: str, *, model: str | None = None, camera: CameraModel | None = None
) -> SegmentationBackend:
    """Build the segmentation backend called ``name``.

    Args:
        name: Backend name (see :func:`known_backends`), case-insensitive.
        model: Model file path or shipped model name, for backends that load one.
        camera: Camera of the images, for backends that use geometry (the classical one).

    Raises:
        BackendUnavailableError: If the name is unknown (the message lists the known ones) or
            the backend cannot run here (e.g. no model available).
    """
    factory = _FACTORIES.get(name.strip().lower())
    if factory is None:
        raise BackendUnavailableError(
            f"unknown segmentation backend {name!r} (known: {', '.join(known_backends())})"
        )
    return factory(model, camera)
