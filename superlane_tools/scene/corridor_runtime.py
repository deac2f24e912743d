"""Ego-corridor runtime: a carded ONNX corridor model, wiper smoothing, and corridor size in metres.

The network (corridor paper, section III) maps a grayscale frame to a per-pixel probability that
the pixel belongs to the ego corridor (the ego lane up to the preceding vehicle). To cope with a
windshield wiper crossing the optical path, :class:`CorridorSmoother` averages the outputs of the
last three frames, as the paper does. Corridor width and length in metres come from
:func:`superlane_tools.corridor.geometry.corridor_from_mask`.
"""

from __future__ import annotations

import os
from collections import deque

import numpy as np
from numpy.typing import NDArray

from superlane_tools.scene.backend import check_image
from superlane_tools.scene.onnx_backend import DEFAULT_CORRIDOR_MODEL, open_model, preprocess

FloatImage = NDArray[np.float32]


class OnnxCorridorModel:
    """Run a carded ego-corridor ONNX model.

    Args:
        model: Model file path or bundled model name (default ``ego_corridor_v3``).
        threads: onnxruntime intra-op threads.

    Raises:
        ModelError: If the model cannot be opened or does not match its card.
    """

    def __init__(self, model: str | os.PathLike[str] | None = None, threads: int = 2) -> None:
        self.model = open_model(model or DEFAULT_CORRIDOR_MODEL, "corridor", threads)
        self.card = self.model.card
        self.name = f"onnx:{self.card.name}"
        self._output = self.card.outputs[0].name

    @property
    def sha256(self) -> str:
        """Hex SHA-256 of the model file, for provenance."""
        return self.model.sha256

    def probability_at_input(self, image_bgr: NDArray[np.uint8]) -> FloatImage:
        """Return the ``(h, w)`` corridor probability at the network's input size."""
        tensor = preprocess(check_image(image_bgr), self.card.input)
        (out,) = self.model.session.run([self._output], {self.card.input.name: tensor})
        prob: FloatImage = np.clip(np.asarray(out, dtype=np.float32)[0, 0], 0.0, 1.0)
        return prob

    def probability(self, image_bgr: NDArray[np.uint8]) -> FloatImage:
        """Return the ``(H, W)`` corridor probability in ``[0, 1]`` at the image's size."""
        import cv2  # late: heavy import

        prob = self.probability_at_input(image_bgr)
        height, width = image_bgr.shape[:2]
        if prob.shape != (height, width):
            prob = np.asarray(
                cv2.resize(prob, (width, height), interpolation=cv2.INTER_LINEAR), np.float32
            )
        return prob


class CorridorSmoother:
    """Windshield-wiper mitigation: the mean of the last ``window`` corridor outputs.

    Args:
        window: Number of frames averaged (3 in the corridor paper).
    """

    def __init__(self, window: int = 3) -> None:
        if window < 1:
            raise ValueError(f"window must be >= 1, got {window}")
        self.window = window
        self._frames: deque[FloatImage] = deque(maxlen=window)

    def reset(self) -> None:
        """Forget past frames (call at a cut between sequences)."""
        self._frames.clear()

    def update(self, probability: FloatImage) -> FloatImage:
        """Add one frame's probability and return the mean over the frames held (<= window).

        A frame of a different size than the held ones restarts the window.
        """
        if self._frames and self._frames[0].shape != probability.shape:
            self._frames.clear()
        self._frames.append(np.asarray(probability, dtype=np.float32))
        mean: FloatImage = np.mean(np.stack(self._frames), axis=0).astype(np.float32)
        return mean
