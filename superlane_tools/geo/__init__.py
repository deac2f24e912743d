"""Geodesy: WGS84 to local ENU, speed/heading and curvature ground truth from trajectories."""

from superlane_tools.geo.curvature import (
    CurvatureParams,
    TrajectoryCurvature,
    fix_speed,
    trajectory_curvature,
)
from superlane_tools.geo.dynamics import (
    DynamicsCurvature,
    DynamicsParams,
    GyroBias,
    gyro_bias,
    yaw_rate_curvature,
)
from superlane_tools.geo.enu import (
    EnuTrajectory,
    GeodeticOrigin,
    geodetic_to_enu,
    parse_origin,
    valid_fixes,
)
from superlane_tools.geo.errors import GeoError
from superlane_tools.geo.noise import curvature_noise_floor
from superlane_tools.geo.quality import DEGRADED_NOTE, FixGrades, grade_fixes
from superlane_tools.geo.trajectory import Kinematics, speed_heading

__all__ = [
    "DEGRADED_NOTE",
    "CurvatureParams",
    "DynamicsCurvature",
    "DynamicsParams",
    "EnuTrajectory",
    "FixGrades",
    "GeoError",
    "GeodeticOrigin",
    "GyroBias",
    "Kinematics",
    "TrajectoryCurvature",
    "curvature_noise_floor",
    "fix_speed",
    "geodetic_to_enu",
    "grade_fixes",
    "gyro_bias",
    "parse_origin",
    "speed_heading",
    "trajectory_curvature",
    "valid_fixes",
    "yaw_rate_curvature",
]
