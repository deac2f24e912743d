"""Training of the scene networks (torch, the optional ``train`` extra) and ONNX export.

This package imports torch only in its submodules; call :func:`require_torch` first to get a
clear message when the extra is missing.
"""

from superlane_tools.training._torch import INSTALL_HINT, require_torch
from superlane_tools.training.errors import TrainingError

__all__ = ["INSTALL_HINT", "TrainingError", "require_torch"]
