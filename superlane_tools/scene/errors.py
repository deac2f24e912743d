"""Errors of the scene layer (segmentation backends)."""

from superlane_tools.errors import SltError, UsageError


class SceneError(SltError):
    """A segmentation backend failed on its input (wrong image shape or type, broken model)."""


class BackendUnavailableError(UsageError):
    """A requested segmentation backend is unknown or cannot run here (no model, missing extra)."""
