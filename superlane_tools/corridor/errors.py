"""Errors of the corridor layer (geometry and availability inputs)."""

from superlane_tools.errors import SltError


class CorridorError(SltError):
    """Corridor inputs are inconsistent (shapes, lengths, windows)."""
