"""Segmentation backends by name: the factory over the classical and ONNX backends.

Kept apart from :mod:`superlane_tools.scene.backend` (the protocol both backends import), so that
the protocol module never imports a backend.
"""

from __future__ import annotations

from collections.abc import Callable

from superlane_tools.camera.model import CameraModel
from superlane_tools.scene.backend import SegmentationBackend
from superlane_tools.scene.errors import BackendUnavailableError

BackendFactory = Callable[[str | None, CameraModel | None], SegmentationBackend]


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


_FACTORIES: dict[str, BackendFactory] = {"classical": _classical, "onnx": _onnx}


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


AUTO_MIN_LANE_IOU = 0.5
"""``auto`` uses the shipped segmentation model only when its model card reports at least this
lane-marking IoU on held-out data; otherwise the classical backend, which is better for lanes."""


def card_lane_iou(model_name: str) -> float:
    """Return the held-out lane-marking IoU stated in a shipped model's card (0 if absent)."""
    from superlane_tools.errors import SltError
    from superlane_tools.scene.model_card import load_card
    from superlane_tools.scene.onnx_backend import resolve_model

    try:
        card = load_card(resolve_model(model_name)[1])
        value = card.metrics.get("sim_heldout", {}).get("lane_marking_iou", 0.0)
        return float(value)
    except (SltError, AttributeError, TypeError, ValueError):
        return 0.0


def auto_backend(model: str) -> tuple[str, str]:
    """Resolve ``auto`` to ``onnx`` or ``classical``; return the name and a note ("" if none).

    An explicit ``model`` means ``onnx``; else the shipped model when it is shipped and its card
    reports a lane-marking IoU of at least :data:`AUTO_MIN_LANE_IOU`, else ``classical``.
    """
    from superlane_tools.models import list_models
    from superlane_tools.scene.onnx_backend import DEFAULT_SEGMENTATION_MODEL

    if model:
        return "onnx", ""
    if DEFAULT_SEGMENTATION_MODEL not in list_models():
        return "classical", (
            f"no shipped segmentation model ({DEFAULT_SEGMENTATION_MODEL}): "
            "fell back to the classical backend"
        )
    iou = card_lane_iou(DEFAULT_SEGMENTATION_MODEL)
    if iou >= AUTO_MIN_LANE_IOU:
        return "onnx", ""
    return "classical", (
        f"shipped model {DEFAULT_SEGMENTATION_MODEL} measured lane-marking IoU "
        f"{iou:.2f} < {AUTO_MIN_LANE_IOU} on held-out simulator data (model card): "
        "the classical backend feeds the lane fit (--backend onnx forces the model)"
    )
