"""The SUPER fit over a drive's frames in order: each frame warm-started from a previous fit.

Ungated, every frame starts from the previous frame's fit, as in the paper (section III). Gated,
only a plausible fit (:meth:`LaneFit.plausible`) seeds the next frames, for at most
:data:`WARM_START_MAX_AGE` frames, so a collapsed fit cannot propagate; a warm-started fit that
collapses is repeated from the loss-curve search and the plausible one kept.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from superlane_tools.camera.model import CameraModel
from superlane_tools.lanes.multilane_fit import fit_frame
from superlane_tools.lanes.params import FitParams
from superlane_tools.lanes.result import LaneFit

if TYPE_CHECKING:
    import numpy as np
    from numpy.typing import NDArray

WARM_START_MAX_AGE = 15
"""Frames a plausible fit may seed the warm start after it (gated warm start), frames."""


def max_plausible_slope(params: FitParams, fraction: float) -> float:
    """Return the largest plausible ``|b|``: ``fraction`` of the slope bound (inf without one).

    At the optimiser's bound the view has collapsed, so a fit near it is not plausible.
    """
    if params.slope and params.slope_bound > 0:
        return fraction * params.slope_bound
    return math.inf


class SequentialFit:
    """Fits frames in order with a warm start, optionally gated by plausibility.

    Args:
        params: Fit parameters.
        max_slope: Largest plausible ``|b|`` (see :func:`max_plausible_slope`).
        gate: Gate the warm start (see the module docstring).
    """

    def __init__(self, params: FitParams, max_slope: float, gate: bool) -> None:
        self.params, self.max_slope, self.gate = params, max_slope, gate
        self._previous: LaneFit | None = None
        self._age = 0

    def reset(self) -> None:
        """Forget the warm start (e.g. after a frame that could not be decoded)."""
        self._previous = None

    def fit(
        self,
        lane_uv: NDArray[np.float64],
        road_uv: NDArray[np.float64] | None,
        camera: CameraModel,
        codes: NDArray[np.intp],
    ) -> LaneFit:
        """Fit the next frame: lane pixels with attribute codes, road pixels or None."""
        prev = self._previous
        init = prev if prev is not None and prev.ok else None
        fit = fit_frame(lane_uv, road_uv, camera, self.params, init=init, attributes=codes)
        if not self.gate:
            self._previous = fit
            return fit
        if init is not None and not fit.plausible(self.max_slope):
            cold = fit_frame(lane_uv, road_uv, camera, self.params, attributes=codes)
            if cold.plausible(self.max_slope):
                fit = cold
        if fit.plausible(self.max_slope):
            self._previous, self._age = fit, 0
        else:
            self._age += 1
            if self._age > WARM_START_MAX_AGE:
                self._previous = None
        return fit
