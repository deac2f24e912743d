"""Errors of the training layer."""

from superlane_tools.errors import SltError


class TrainingError(SltError):
    """Training, export or evaluation of a model failed (missing extra, bad dataset, ...)."""
