"""``slt camera estimate``: a camera's mounting from a recording's lane lines, as a profile."""

from superlane_tools.commands.camera_estimate.estimate import CameraEstimate, estimate_camera
from superlane_tools.commands.camera_estimate.run import (
    EstimateOutput,
    EstimateParams,
    profile_target,
    run,
)

__all__ = [
    "CameraEstimate",
    "EstimateOutput",
    "EstimateParams",
    "estimate_camera",
    "profile_target",
    "run",
]
