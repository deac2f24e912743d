"""Errors of the fleet layer (comparing runs, mining frames)."""

from __future__ import annotations

from superlane_tools.errors import SltError


class FleetError(SltError):
    """Runs that cannot be compared or mined: not a run, incompatible tables, an empty fleet."""
