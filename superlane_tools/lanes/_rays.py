"""Usable lane and road pixels of a frame as viewing rays ``(iq, r)`` from the camera foot."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from superlane_tools.camera.model import CameraModel
from superlane_tools.lanes.cost import kernels
from superlane_tools.lanes.errors import LaneFitError
from superlane_tools.lanes.params import FitParams

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.intp]


class RayPoints:
    """Usable pixels as viewing rays ``(iq, r)`` from the camera foot (see ``cost``)."""

    def __init__(self, camera: CameraModel, uv: FloatArray | None, params: FitParams) -> None:
        pix = np.empty((0, 2)) if uv is None else np.asarray(uv, dtype=np.float64).reshape(-1, 2)
        if pix.size and not np.all(np.isfinite(pix)):
            raise LaneFitError("pixel coordinates must be finite")
        self.n_pixels = pix.shape[0]
        if self.n_pixels == 0:
            self.iq = self.r = self.rows = np.empty(0)
            self.index = np.empty(0, dtype=np.intp)
            return
        height = camera.extrinsics.height_m
        # Keep rays that meet the road within range for some admissible slope; a vertical
        # curvature term c acts as the extra slope c * x over the range.
        reach = (
            (params.slope_bound + params.vertical_curvature_bound * params.max_range_m) / height
            if params.slope
            else 0.0
        )
        if params.backend == "numba":
            xn, yn = camera.normalized(pix)
            iq, r, keep = kernels().ray_slopes(
                np.ascontiguousarray(xn),
                np.ascontiguousarray(yn),
                np.ascontiguousarray(camera.extrinsics.rotation, dtype=np.float64),
                height,
                reach,
                1.0 / params.max_range_m,
                1.0 / params.min_range_m,
            )
        else:
            dirs = camera.rays(pix)
            forward = dirs[:, 0] > 1e-9
            dx = np.where(forward, dirs[:, 0], 1.0)
            iq = -dirs[:, 2] / (height * dx)
            r = dirs[:, 1] / dx
            keep = (
                forward
                & (iq + reach >= 1.0 / params.max_range_m)
                & (iq - reach <= 1.0 / params.min_range_m)
            )
        self.index = np.flatnonzero(keep)
        self.iq, self.r, self.rows = iq[keep], r[keep], pix[keep, 1]

    @property
    def size(self) -> int:
        return int(self.iq.size)

    def sample(self, n_max: int, seed: int) -> IntArray:
        """Return sorted indices of a deterministic uniform subsample (image-pixel density)."""
        if self.size <= n_max:
            return np.arange(self.size)
        rng = np.random.default_rng(seed)
        return np.sort(rng.choice(self.size, n_max, replace=False))
