"""Load training checkpoints safely: tensors and plain containers only, never pickled code."""

from __future__ import annotations

import pickle
from pathlib import Path
from typing import Any

from superlane_tools.training._torch import require_torch
from superlane_tools.training.errors import TrainingError


def _unsafe_globals(path: Path) -> list[str]:
    """Return the classes/functions a checkpoint would have to import (torch's own scan)."""
    torch = require_torch()
    try:
        return list(torch.serialization.get_unsafe_globals_in_checkpoint(path))
    except Exception:  # only words the refusal; the weights-only load already failed
        return []


def load_checkpoint(path: Path, what: str, map_location: Any = "cpu") -> dict[str, Any]:
    """Load a checkpoint with ``torch.load(weights_only=True)``; refuse anything more.

    A checkpoint that needs other objects (a custom class, a function to call) could run
    arbitrary code when unpickled, so it is refused rather than loaded.

    Args:
        path: The checkpoint file (``torch.save`` of a dict with at least ``model``).
        what: Where it came from, for messages (``--init ckpt.pt``).
        map_location: Device the tensors are loaded onto.

    Returns:
        The checkpoint's dict.

    Raises:
        TrainingError: If the file is missing, unreadable, not a weights-only checkpoint, or
            not a dict holding ``model``.
    """
    torch = require_torch()
    if not path.is_file():
        raise TrainingError(f"{what}: no such checkpoint")
    try:
        state = torch.load(path, map_location=map_location, weights_only=True)
    except pickle.UnpicklingError as err:
        names = _unsafe_globals(path)
        holds = f" ({', '.join(names)})" if names else ""
        raise TrainingError(
            f"{what}: refused: the checkpoint holds objects other than weights{holds}, "
            "which could run code when loaded; only weights-only checkpoints are read"
        ) from err
    except Exception as err:  # torch/zipfile raise many types for a damaged file
        raise TrainingError(f"{what}: cannot read checkpoint: {type(err).__name__}") from err
    if not isinstance(state, dict) or "model" not in state:
        raise TrainingError(f"{what}: not a training checkpoint (no 'model' weights)")
    return state


def save_checkpoint(path: Path, state: dict[str, Any]) -> Path:
    """Write a checkpoint atomically (a crash mid-write leaves the previous one whole).

    Args:
        path: Target file; its folder is created.
        state: Tensors and plain containers only (what :func:`load_checkpoint` reads back).
    """
    from superlane_tools.reporting.atomic import atomic_path

    torch = require_torch()
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path, suffix=".pt") as tmp:
        torch.save(state, tmp)
    return path
