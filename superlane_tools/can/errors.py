"""Errors of the CAN layer (DBC loading and signal decoding)."""

from superlane_tools.errors import SltError


class CanError(SltError):
    """A DBC file could not be loaded (even after repairs) or CAN data could not be decoded."""
