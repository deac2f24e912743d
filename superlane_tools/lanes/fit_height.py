"""The camera height at which the lane fit measures a known lane width (``slt camera estimate``)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from superlane_tools.camera.extrinsics_estimate import ExtrinsicsEstimate
from superlane_tools.camera.model import CameraModel
from superlane_tools.lanes.params import FitParams

FIT_ITERATIONS = 5
"""Most rounds of fitting and rescaling the height (each round fits every sampled frame)."""
FIT_TOLERANCE = 0.002
"""Relative change of the height below which the rounds stop."""
LanePixels = tuple[NDArray[np.float64], NDArray[np.intp]]


def fit_height(
    frames: list[LanePixels],
    camera: CameraModel,
    estimate: ExtrinsicsEstimate,
    lane_width_m: float,
    params: FitParams,
) -> ExtrinsicsEstimate:
    """Scale the height so that the lane fit of ``slt reprocess`` measures ``lane_width_m``.

    The vanishing-point geometry and the multi-lane fit read a lane's width from different
    pixels: the former from two straight lines through the lower image, the latter from all
    marking pixels with its own choice of the ego pair, curvature and slope. On real frames
    the two disagree (8 real Udacity frames, 60 degree lens assumed: the fit measured a median
    4.34 m where the estimate assumed 3.7 m). Every ground distance of the fit is proportional
    to the camera height, so the height that makes the fit's median ego-lane width equal the
    assumed width is found by rescaling it, a few rounds because the fit's bins and priors are
    in metres.

    Args:
        frames: Lane-marking pixels and attribute codes of each sampled frame
            (:func:`~superlane_tools.lanes.points.lane_points`).
        camera: Intrinsics at the frames' size, with the vanishing-point extrinsics.
        estimate: The vanishing-point estimate.
        lane_width_m: Lane width of the road driven, metres.
        params: The lane fit's parameters (those of ``slt reprocess``).

    Returns:
        The estimate with the fitted height (unchanged when fewer than 3 frames have an ego
        lane).
    """
    from superlane_tools.lanes.multilane_fit import fit_frame

    extrinsics = estimate.extrinsics
    used = 0
    for _ in range(FIT_ITERATIONS):
        cam = CameraModel(camera.intrinsics, extrinsics)
        widths = [fit_frame(uv, None, cam, params, attributes=c).lane_width_m for uv, c in frames]
        finite = [w for w in widths if math.isfinite(w) and w > 0]
        if len(finite) < 3:
            break
        used = len(finite)
        scale = lane_width_m / float(np.median(finite))
        extrinsics = replace(extrinsics, height_m=extrinsics.height_m * scale)
        if abs(scale - 1.0) < FIT_TOLERANCE:
            break
    if not used:
        return estimate
    ratio = extrinsics.height_m / estimate.extrinsics.height_m
    return replace(
        estimate,
        extrinsics=extrinsics,
        height_sigma_m=estimate.height_sigma_m * ratio,
        vp_height_m=estimate.extrinsics.height_m,
        fit_frames=used,
    )
