"""Static INT8 quantisation: a loadable model close to the float one; the real calibration split."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from superlane_tools.scene.adapters.heads import decode_heads
from superlane_tools.scene.model_card import load_card
from superlane_tools.scene.onnx_backend import resolve_model, upsample_scores
from superlane_tools.training.errors import TrainingError
from superlane_tools.training.quantize import network_input, quantize_model, tusimple_split
from superlane_tools.training.toy_dataset import toy_frame

pytest.importorskip("onnx")


def _leaf(path: Path, tensor: np.ndarray, card: object) -> np.ndarray:
    import onnxruntime as ort

    heads = card.heads()  # type: ignore[attr-defined]
    session = ort.InferenceSession(str(path), providers=["CPUExecutionProvider"])
    outputs = session.run([h.name for h in heads], {"image": tensor})
    spec = card.input  # type: ignore[attr-defined]
    return decode_heads(upsample_scores(outputs, spec), heads)


def test_quantized_segmentation_stays_close_to_float(tmp_path: Path) -> None:
    src, card_path = resolve_model("super_seg_v2")
    card = load_card(card_path)
    frames = []
    rng = np.random.default_rng(0)
    for seed in range(3):
        image, _labels, _corridor = toy_frame(rng, 1280, 720)
        frames.append(tmp_path / f"f{seed}.png")
        cv2.imwrite(str(frames[-1]), image)
    out = tmp_path / "int8.onnx"
    quantize_model(src, out, frames[:2], card.input)
    assert 0 < out.stat().st_size < src.stat().st_size / 2  # 8-bit weights
    tensor = network_input(frames[2], card.input)
    assert tensor.shape == card.input.shape
    changed = np.mean(_leaf(out, tensor, card) != _leaf(src, tensor, card))
    assert changed < 0.2  # a toy frame; bench_quantize.py measures real frames
    with pytest.raises(TrainingError, match="layout"):
        quantize_model(src, out, frames, card.input, "fp8")
    with pytest.raises(TrainingError, match="calibration"):
        quantize_model(src, out, [], card.input)


@pytest.mark.realdata
def test_calibration_split_never_holds_the_laneeval_frames(realdata: Path) -> None:
    train, val = tusimple_split(realdata, "train"), tusimple_split(realdata, "val")
    assert len(val) == 30
    assert train
    assert not set(train) & set(val)
