"""Static INT8 quantisation of a carded segmentation model, calibrated on real TuSimple frames.

``onnxruntime.quantization.quantize_static`` with u8 activations, s8 per-channel weights and
MinMax calibration. The calibration frames are the real TuSimple ``train_frames`` training split
(never the 30 frames held out for the real-frame LaneEval), preprocessed exactly as
``slt reprocess`` feeds the network: decoded, resized to 640 pixels wide, then the card's resize
and normalisation. Needs the ``train`` extra (``onnx``, for the pre-processing pass).
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from superlane_tools.scene.model_card import InputSpec
from superlane_tools.training.errors import TrainingError

LAYOUTS = ("qdq_all", "qdq_conv", "qoperator_conv_concat")
"""``qdq_all``: QDQ around every operator; ``qdq_conv``: QDQ around convolutions only;
``qoperator_conv_concat``: QLinearConv / QLinearConcat operators."""

PROCESS_WIDTH = 640
"""Width ``slt reprocess`` resizes frames to before the network's own resize (its default)."""


def tusimple_split(data: Path, split: str) -> list[Path]:
    """Return the frames of the TuSimple ``train_frames`` ``train`` or ``val`` split.

    Raises:
        TrainingError: If the labels cannot be read.
    """
    from superlane_tools.training.datasets import (
        TUSIMPLE_VAL_FRAMES,
        _split_rows,
        tusimple_labels,
    )

    folder = data / "tusimple" / "train_frames"
    labels = tusimple_labels(folder)
    rows = labels[_split_rows(len(labels), split, TUSIMPLE_VAL_FRAMES)]
    return [folder / row["raw_file"] for row in rows]


def network_input(path: Path, spec: InputSpec) -> NDArray[np.float32]:
    """Return the network input of one image file as ``slt reprocess`` builds it."""
    import cv2

    from superlane_tools.scene.onnx_backend import preprocess

    image = cv2.imread(str(path))
    if image is None:
        raise TrainingError(f"cannot read image {path}")
    height = round(image.shape[0] * PROCESS_WIDTH / image.shape[1])
    small = cv2.resize(image, (PROCESS_WIDTH, height), interpolation=cv2.INTER_AREA)
    return preprocess(np.asarray(small, np.uint8), spec)


def quantize_model(
    src: str | os.PathLike[str],
    dst: str | os.PathLike[str],
    calibration: Sequence[Path],
    spec: InputSpec,
    layout: str = "qdq_all",
) -> None:
    """Write the static INT8 version of ``src`` to ``dst``.

    Args:
        src: Float ONNX model.
        dst: Quantised ONNX model to write.
        calibration: Image files the activation ranges are taken from.
        spec: The model card's input specification.
        layout: One of :data:`LAYOUTS`.

    Raises:
        TrainingError: For an unknown layout or no calibration frames.
    """
    from onnxruntime.quantization import (
        CalibrationDataReader,
        CalibrationMethod,
        QuantFormat,
        QuantType,
        quantize_static,
    )
    from onnxruntime.quantization.shape_inference import quant_pre_process

    if layout not in LAYOUTS:
        raise TrainingError(f"unknown layout {layout!r} (known: {', '.join(LAYOUTS)})")
    if not calibration:
        raise TrainingError("no calibration frames")
    fmt, ops = {
        "qdq_all": (QuantFormat.QDQ, None),
        "qdq_conv": (QuantFormat.QDQ, ["Conv"]),
        "qoperator_conv_concat": (QuantFormat.QOperator, ["Conv", "Concat"]),
    }[layout]

    class _Frames(CalibrationDataReader):  # type: ignore[misc]
        def __init__(self) -> None:
            self._paths = iter(calibration)

        def get_next(self) -> dict[str, NDArray[np.float32]] | None:
            path = next(self._paths, None)
            return None if path is None else {spec.name: network_input(path, spec)}

    with tempfile.TemporaryDirectory() as tmp:
        pre = Path(tmp) / "pre.onnx"
        quant_pre_process(str(src), str(pre), skip_symbolic_shape=True)
        quantize_static(
            str(pre),
            str(dst),
            _Frames(),
            quant_format=fmt,
            op_types_to_quantize=ops,
            per_channel=True,
            activation_type=QuantType.QUInt8,
            weight_type=QuantType.QInt8,
            calibrate_method=CalibrationMethod.MinMax,
        )
