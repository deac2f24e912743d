"""Errors of the geodesy layer."""

from superlane_tools.errors import SltError


class GeoError(SltError):
    """Geodetic input that cannot be converted (no valid fix, bad origin, mismatched arrays)."""
