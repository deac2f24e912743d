"""The shipped models: every ONNX file has a card, and each card names the file's bytes."""

from __future__ import annotations

from superlane_tools.models import MODELS_DIR, list_models
from superlane_tools.reporting import file_sha256
from superlane_tools.scene.model_card import load_card


def test_every_onnx_file_has_a_card() -> None:
    onnx = sorted(p.name.removesuffix(".onnx") for p in MODELS_DIR.glob("*.onnx"))
    assert onnx, "no shipped models"
    assert list_models() == onnx


def test_each_card_names_its_file_and_its_sha256() -> None:
    for name in list_models():
        card = load_card(MODELS_DIR / f"{name}.card.yaml")
        assert card.name == name
        assert card.sha256 == file_sha256(MODELS_DIR / f"{name}.onnx"), name
