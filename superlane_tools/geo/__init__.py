"""Geodesy: WGS84 to local ENU, speed/heading and curvature ground truth from trajectories."""

from superlane_tools.geo.curvature import CurvatureParams, TrajectoryCurvature, trajectory_curvature
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
    "CurvatureParams",
    "EnuTrajectory",
    "GeoError",
    "GeodeticOrigin",
    "Kinematics",
    "TrajectoryCurvature",
    "geodetic_to_enu",
    "parse_origin",
    "speed_heading",
    "trajectory_curvature",
    "valid_fixes",
]
