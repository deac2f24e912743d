"""Errors of the output layer."""

from superlane_tools.errors import SltError


class OutputError(SltError):
    """An output file could not be written or read back."""
