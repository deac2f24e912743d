"""Errors of the drive layer."""

from __future__ import annotations

from superlane_tools.errors import SltError


class DriveError(SltError):
    """A drive with nothing to reprocess (no camera, CAN or GNSS stream)."""
