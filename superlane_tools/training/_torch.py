"""Late, guarded import of torch: training is the optional ``train`` extra."""

from __future__ import annotations

from types import ModuleType

from superlane_tools.training.errors import TrainingError

INSTALL_HINT = "pip install 'superlane-tools[train]'"


def require_torch() -> ModuleType:
    """Return the ``torch`` module, or fail with a message naming the extra to install.

    Raises:
        TrainingError: If torch is not installed.
    """
    try:
        import torch
    except ImportError as err:
        raise TrainingError(
            f"training needs torch and onnx; install them with {INSTALL_HINT}"
        ) from err
    return torch
