"""Geodesy: WGS84 to local ENU, and speed/heading from ENU trajectories."""

from superlane_tools.geo.enu import (
    EnuTrajectory,
    GeodeticOrigin,
    geodetic_to_enu,
    parse_origin,
    valid_fixes,
)
from superlane_tools.geo.errors import GeoError
from superlane_tools.geo.trajectory import Kinematics, speed_heading

__all__ = [
    "EnuTrajectory",
    "GeoError",
    "GeodeticOrigin",
    "Kinematics",
    "geodetic_to_enu",
    "parse_origin",
    "speed_heading",
    "valid_fixes",
]
