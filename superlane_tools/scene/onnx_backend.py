"""ONNX segmentation backend: a carded ONNX model run with onnxruntime, decoded down the hierarchy.

Models are named by path (``my_model.onnx`` with ``my_model.card.yaml`` beside it) or by the name
of a bundled model in :mod:`superlane_tools.models` (e.g. ``super_seg_v2``). onnxruntime is
imported only when a model is opened.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from functools import cache
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from superlane_tools.models import MODELS_DIR, list_models
from superlane_tools.scene.adapters.heads import decode_heads
from superlane_tools.scene.backend import check_image
from superlane_tools.scene.model_card import (
    InputSpec,
    ModelCard,
    card_path_for,
    check_session,
    load_card,
    verify_sha256,
)
from superlane_tools.scene.model_errors import ModelError

DEFAULT_SEGMENTATION_MODEL = "super_seg_v4"
"""Default segmentation model: the one :mod:`superlane_tools.scene.default_rule` picks from the
shipped cards (no worse than any shipped model on every set, and fast enough; a test checks
that this name is its pick). Trained on real TuSimple and CamVid frames and simulated ones
(docs/models.md). CamVid is CC BY-NC 4.0: for commercial use pass ``--model super_seg_v2``
(simulator only) or ``--backend classical``."""
DEFAULT_CORRIDOR_MODEL = "ego_corridor_v3"
"""Default corridor model: trained on real TuSimple ego lanes and simulated frames (corridor IoU
0.944 on the real validation frames against 0.885 for the simulator-trained v2)."""


class LoadedModel(NamedTuple):
    """An opened, verified model.

    Attributes:
        path: The ONNX file.
        card: Its model card.
        sha256: Hex SHA-256 of the file (verified against the card).
        session: The ``onnxruntime.InferenceSession``.
    """

    path: Path
    card: ModelCard
    sha256: str
    session: Any


def resolve_model(name_or_path: str | os.PathLike[str]) -> tuple[Path, Path]:
    """Return ``(model path, card path)`` for a model file path or a bundled model name.

    Raises:
        ModelError: If neither a file nor a bundled model has that name.
    """
    text = str(name_or_path)
    path = Path(text).expanduser()
    if path.suffix == ".onnx" or path.exists() or os.sep in text:
        if not path.is_file():
            raise ModelError(f"model file not found: {path}")
        return path, card_path_for(path)
    bundled = MODELS_DIR / f"{text}.onnx"
    if not bundled.is_file():
        known = ", ".join(list_models()) or "none"
        raise ModelError(f"unknown model {text!r}: not a file, not a bundled model ({known})")
    return bundled, card_path_for(bundled)


def open_model(name_or_path: str | os.PathLike[str], task: str, threads: int = 2) -> LoadedModel:
    """Open a model after checking it against its card.

    Args:
        name_or_path: Model file or bundled model name.
        task: Required card task (``segmentation`` or ``corridor``).
        threads: onnxruntime intra-op threads (CPU cores used per inference).

    Raises:
        ModelError: If the card is missing or invalid, the sha256 or the input/output
            names and shapes differ from the card, the task is wrong, or onnxruntime fails.
    """
    path, card_path = resolve_model(name_or_path)
    card = load_card(card_path)
    if card.task != task:
        raise ModelError(f"{path} is a {card.task} model, not a {task} model")
    digest = verify_sha256(card, path)
    import onnxruntime as ort  # late: heavy import

    options = ort.SessionOptions()
    # Every graph optimisation, NCHWc layouts included (measured on super_seg_v2, one thread:
    # 24 ms against 43 ms with ORT_ENABLE_EXTENDED); a chain of convolutions gains nothing
    # from running nodes in parallel, so one inter-op thread and sequential execution.
    options.graph_optimization_level = ort.GraphOptimizationLevel.ORT_ENABLE_ALL
    options.execution_mode = ort.ExecutionMode.ORT_SEQUENTIAL
    options.intra_op_num_threads = max(1, int(threads))
    options.inter_op_num_threads = 1
    options.log_severity_level = 3
    try:
        session = ort.InferenceSession(
            str(path), sess_options=options, providers=["CPUExecutionProvider"]
        )
    except Exception as err:  # onnxruntime raises its own untyped errors
        raise ModelError(f"onnxruntime cannot load {path}: {err}") from err
    check_session(card, session, str(path))
    return LoadedModel(path, card, digest, session)


def preprocess(image_bgr: NDArray[np.uint8], spec: InputSpec) -> NDArray[np.float32]:
    """Resize and normalise a BGR image into the card's ``(1, C, H, W)`` float32 tensor.

    Each value is ``(pixel / 255 - mean) / std`` in float32; the 256 possible values per channel
    come from a table, gathered straight into the planar layout (no float image, no transpose).
    """
    import cv2  # late: heavy import

    size = (spec.width, spec.height)
    resized = np.asarray(cv2.resize(image_bgr, size, interpolation=cv2.INTER_AREA), np.uint8)
    planes: list[NDArray[np.uint8]]
    if spec.color_order == "GRAY":
        planes = [np.asarray(cv2.cvtColor(resized, cv2.COLOR_BGR2GRAY), np.uint8)]
    else:
        order = (2, 1, 0) if spec.color_order == "RGB" else (0, 1, 2)
        planes = [resized[:, :, c] for c in order]
    tables = _normalise_tables(spec.mean, spec.std)
    out = np.empty((1, len(planes), spec.height, spec.width), dtype=np.float32)
    for channel, plane in enumerate(planes):
        np.take(tables[channel], plane, out=out[0, channel], mode="clip")
    return out


@cache
def _normalise_tables(mean: tuple[float, ...], std: tuple[float, ...]) -> NDArray[np.float32]:
    """Return ``(C, 256)`` float32 ``(v / 255 - mean) / std`` for every pixel value ``v``."""
    values = np.arange(256, dtype=np.float32)[:, None]
    table = (values / 255.0 - np.asarray(mean, np.float32)) / np.asarray(std, np.float32)
    out: NDArray[np.float32] = np.ascontiguousarray(table.T, dtype=np.float32)
    out.flags.writeable = False
    return out


def upsample_scores(
    outputs: Sequence[NDArray[np.floating]], spec: InputSpec
) -> list[NDArray[np.float32]]:
    """Return a segmentation network's ``(1, C_k, h, w)`` outputs as ``(C_k, H, W)`` at input size.

    The shipped segmentation graphs end at their classifier, at half the input resolution
    (docs/models.md, "Output resolution"); the bilinear upsampling that training applies runs
    here, one plane at a time with OpenCV: ``cv2.INTER_LINEAR`` samples at half-pixel centres,
    as ``F.interpolate(..., align_corners=False)`` and ONNX ``Resize`` (``half_pixel``) do, and
    agrees with them to float rounding (about 1e-7). On one thread that is 0.6-1.3 ms for the 23
    planes at 512x288, against about 4 ms for onnxruntime's own Resize, layout reorder and Split
    at the full size. Outputs already at the input size are returned as they are.
    """
    import cv2  # late: heavy import

    heads = [np.asarray(output[0], dtype=np.float32) for output in outputs]
    if all(h.shape[1:] == (spec.height, spec.width) for h in heads):
        return heads
    size = (spec.width, spec.height)
    # One block for every head (views into it): one allocation per frame, not one per head.
    block = np.empty((sum(h.shape[0] for h in heads), spec.height, spec.width), np.float32)
    planes, start = [], 0
    for head in heads:
        out = block[start : start + head.shape[0]]
        start += head.shape[0]
        for channel in range(head.shape[0]):
            cv2.resize(head[channel], size, dst=out[channel], interpolation=cv2.INTER_LINEAR)
        planes.append(out)
    return planes


def resize_labels(labels: NDArray[np.uint8], width: int, height: int) -> NDArray[np.uint8]:
    """Resize a label image with nearest-neighbour sampling (ids never blend)."""
    import cv2  # late: heavy import

    if labels.shape == (height, width):
        return labels
    resized = cv2.resize(labels, (width, height), interpolation=cv2.INTER_NEAREST)
    return np.asarray(resized, dtype=np.uint8)


class OnnxSegmentationBackend:
    """Segmentation backend running a carded hierarchical ONNX model.

    Implements the ``SegmentationBackend`` protocol: ``segment`` returns leaf ids at the input
    image's resolution (decoded at the network's resolution, then resized nearest-neighbour).

    Args:
        model: Model file path or bundled model name (default :data:`DEFAULT_SEGMENTATION_MODEL`).
        threads: onnxruntime intra-op threads.

    Raises:
        ModelError: If the model cannot be opened or does not match its card.
    """

    def __init__(self, model: str | os.PathLike[str] | None = None, threads: int = 2) -> None:
        self.model = open_model(model or DEFAULT_SEGMENTATION_MODEL, "segmentation", threads)
        self.card = self.model.card
        self.name = f"onnx:{self.card.name}"
        self._heads = self.card.heads()
        self._names = [h.name for h in self._heads]

    @property
    def sha256(self) -> str:
        """Hex SHA-256 of the model file, for provenance."""
        return self.model.sha256

    def scores(self, image_bgr: NDArray[np.uint8]) -> list[NDArray[np.float32]]:
        """Return the per-head ``(C_k, h, w)`` logits at the network's input size."""
        tensor = preprocess(check_image(image_bgr), self.card.input)
        outputs = self.model.session.run(self._names, {self.card.input.name: tensor})
        return upsample_scores(outputs, self.card.input)

    def segment(self, image_bgr: NDArray[np.uint8]) -> NDArray[np.uint8]:
        """Return the ``(H, W)`` uint8 leaf-id image of one BGR image."""
        leaf = decode_heads(self.scores(image_bgr), self._heads)
        return resize_labels(leaf, image_bgr.shape[1], image_bgr.shape[0])

    def segment_batch(self, images_bgr: Sequence[NDArray[np.uint8]]) -> list[NDArray[np.uint8]]:
        """Return the leaf-id images of several BGR images (one inference each)."""
        return [self.segment(image) for image in images_bgr]
