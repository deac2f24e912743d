"""Errors of the lane-fitting layer."""

from superlane_tools.errors import SltError, UsageError


class LaneFitError(SltError):
    """A lane fit request cannot be carried out (inconsistent inputs)."""


class FitParamsError(UsageError):
    """A lane-fit parameter is invalid."""
