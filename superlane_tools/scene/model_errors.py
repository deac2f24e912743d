"""Errors of the model runtimes: a model file that is missing, broken or does not match its card."""

from superlane_tools.scene.errors import SceneError


class ModelError(SceneError):
    """A model or its card is missing, invalid, or they do not match (sha256, inputs, outputs)."""
