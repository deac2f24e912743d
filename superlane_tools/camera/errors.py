"""Errors of the camera layer."""

from superlane_tools.errors import SltError


class CameraError(SltError):
    """A camera profile, calibration file or projection request is invalid."""
