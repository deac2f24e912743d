"""Shipped ONNX models and their model cards (``NAME.onnx`` + ``NAME.card.yaml``)."""

from pathlib import Path

MODELS_DIR = Path(__file__).resolve().parent
"""Folder holding the bundled models."""


def list_models() -> list[str]:
    """Return the names of the bundled models that have both a file and a card, sorted."""
    return sorted(
        p.name.removesuffix(".onnx")
        for p in MODELS_DIR.glob("*.onnx")
        if (MODELS_DIR / (p.name.removesuffix(".onnx") + ".card.yaml")).is_file()
    )


__all__ = ["MODELS_DIR", "list_models"]
