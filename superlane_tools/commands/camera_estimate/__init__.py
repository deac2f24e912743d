"""``slt camera estimate``: a camera's mounting from a recording's lane lines, as a profile.

The names below load their module on first use (PEP 562), so that the profile's path is
checked (:func:`~superlane_tools.commands.camera_estimate.run.profile_target`) before the
estimate's imports. The entry is :func:`superlane_tools.commands.camera_estimate.run.run`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from superlane_tools._lazy import lazy_attributes

if TYPE_CHECKING:
    from superlane_tools.commands.camera_estimate.estimate import CameraEstimate, estimate_camera
    from superlane_tools.commands.camera_estimate.run import (
        EstimateOutput,
        EstimateParams,
        profile_target,
    )

_HOMES = {
    "CameraEstimate": "superlane_tools.commands.camera_estimate.estimate",
    "EstimateOutput": "superlane_tools.commands.camera_estimate.run",
    "EstimateParams": "superlane_tools.commands.camera_estimate.run",
    "estimate_camera": "superlane_tools.commands.camera_estimate.estimate",
    "profile_target": "superlane_tools.commands.camera_estimate.run",
}


__getattr__ = lazy_attributes(__name__, globals(), _HOMES)


__all__ = [
    "CameraEstimate",
    "EstimateOutput",
    "EstimateParams",
    "estimate_camera",
    "profile_target",
]
