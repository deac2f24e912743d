"""Per-camera pixel ray grids, cached on the frozen camera model."""

from __future__ import annotations

from functools import lru_cache
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from superlane_tools.camera.model import CameraModel

F32 = NDArray[np.float32]


class CameraRays(NamedTuple):
    """Unit ray directions of every pixel centre and quantities derived from them.

    Attributes:
        dirs: ``(H, W, 3)`` unit ray directions in the vehicle frame.
        origin: Optical centre in the vehicle frame, metres.
        slope_z: ``(H, W)`` ray rise per metre forward (``dz / dx``); +inf for rays not forward.
        slope_y: ``(H, W)`` ray lateral drift per metre forward (``dy / dx``).
        range_per_x: ``(H, W)`` ray length per metre forward (``1 / dx``).
        elevation: ``(H, W)`` ray elevation above the horizontal plane, radians.
        azimuth: ``(H, W)`` ray azimuth, radians, left positive.
        row_min_slope: ``(H,)`` smallest ``slope_z`` of each row (rows are scanned from the top).
        per_row: True when ``slope_z`` is constant along rows (no roll, no distortion).
        mirror_u: ``(H, W)`` column of the pixel seeing the direction mirrored in the horizontal
            plane (for wet-road reflections); -1 outside the image.
        mirror_v: ``(H, W)`` row of that pixel.
        vignette: ``(H, W)`` relative illumination (cos^4 law, 1 at the principal point).
        mirror_fade: ``(H, W)`` 0..1 fade of wet-road reflections where the mirrored direction
            leaves the image (no hard reflection border).
    """

    dirs: F32
    origin: NDArray[np.float64]
    slope_z: F32
    slope_y: F32
    range_per_x: F32
    elevation: F32
    azimuth: F32
    row_min_slope: F32
    per_row: bool
    mirror_u: F32
    mirror_v: F32
    vignette: F32
    mirror_fade: F32


@lru_cache(maxsize=8)
def camera_rays(camera: CameraModel) -> CameraRays:
    """Return the (cached) ray grid of ``camera``."""
    h, w = camera.height, camera.width
    vv, uu = np.mgrid[0:h, 0:w]
    uv = np.stack([uu.ravel(), vv.ravel()], axis=1).astype(np.float64)
    dirs = camera.rays(uv)
    dx, dy, dz = dirs[:, 0], dirs[:, 1], dirs[:, 2]
    forward = dx > 1e-6
    with np.errstate(divide="ignore", invalid="ignore"):
        slope_z = np.where(forward, dz / dx, np.inf)
        slope_y = np.where(forward, dy / dx, 0.0)
        range_per_x = np.where(forward, 1.0 / dx, np.inf)
    elevation = np.arcsin(np.clip(dz, -1.0, 1.0))
    azimuth = np.arctan2(dy, dx)
    mirrored = np.stack([dx, dy, -dz], axis=1)
    origin = camera.extrinsics.position
    muv, front = camera.project(origin + mirrored * 100.0)
    inside = (
        front
        & (muv[:, 0] >= -0.5)
        & (muv[:, 0] <= w - 0.5)
        & (muv[:, 1] >= -0.5)
        & (muv[:, 1] <= h - 0.5)
    )
    mirror_u = np.where(inside, muv[:, 0], -1.0)
    mirror_v = np.where(inside, muv[:, 1], -1.0)
    # cos^4 fall-off of a real lens, softened: the optical axis direction is the camera's z axis.
    axis = camera.extrinsics.rotation[:, 2]
    cos_a = np.clip(dirs @ axis, 0.0, 1.0)
    vignette = 0.55 + 0.45 * cos_a**4

    def grid(a: NDArray[np.float64]) -> F32:
        return np.ascontiguousarray(a.reshape(h, w), dtype=np.float32)

    sz = grid(slope_z)
    finite = np.where(np.isfinite(sz), sz, np.float32(np.inf))
    row_min = finite.min(axis=1)
    spread = np.nanmax(np.abs(finite - finite[:, :1]), axis=1) if w > 1 else np.zeros(h)
    per_row = bool(np.all(np.isfinite(finite)) and float(np.max(spread)) < 1e-7)
    return CameraRays(
        dirs=np.ascontiguousarray(dirs.reshape(h, w, 3), dtype=np.float32),
        origin=origin,
        slope_z=sz,
        slope_y=grid(slope_y),
        range_per_x=grid(range_per_x),
        elevation=grid(elevation),
        azimuth=grid(azimuth),
        row_min_slope=row_min.astype(np.float32),
        per_row=per_row,
        mirror_u=grid(mirror_u),
        mirror_v=grid(mirror_v),
        vignette=grid(vignette),
        mirror_fade=grid(
            np.clip(mirror_v / 250.0, 0.0, 1.0)
            * np.clip(np.minimum(mirror_u, (w - 1) - mirror_u) / 60.0, 0.0, 1.0)
        ),
    )
