"""Inverse perspective mapping: image pixels <-> flat-road points in the vehicle frame, BEV images.

The vehicle frame is this package's (``x`` forward, ``y`` left, ``z`` up, metres; see
:mod:`superlane_tools.camera.model`). The road is the plane ``z = 0``; for sloped roads correct the
flat-ground points with :mod:`superlane_tools.camera.slope`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from superlane_tools.camera.errors import CameraError
from superlane_tools.camera.model import BoolArray, CameraModel, FloatArray


def image_to_ground(
    camera: CameraModel, uv: FloatArray
) -> tuple[FloatArray, FloatArray, BoolArray]:
    """Intersect the rays of ``(N, 2)`` pixels with the flat road ``z = 0``.

    Args:
        camera: The camera.
        uv: Pixel coordinates ``(u column, v row)``, distorted as in the image.

    Returns:
        ``x_fwd`` and ``y_left`` in metres (vehicle frame), and a mask of pixels whose ray hits
        the road ahead of the camera; other entries are NaN.
    """
    xy, valid = camera.ground_points(uv)
    return xy[:, 0].copy(), xy[:, 1].copy(), valid


def ground_to_image(
    camera: CameraModel,
    x_fwd: FloatArray,
    y_left: FloatArray,
    z_up: FloatArray | float = 0.0,
) -> FloatArray:
    """Project vehicle-frame points (metres) to ``(N, 2)`` pixels.

    Args:
        camera: The camera.
        x_fwd: Forward coordinates, metres.
        y_left: Left coordinates, metres (broadcast with ``x_fwd``).
        z_up: Heights above the flat road, metres (scalar or broadcast).

    Returns:
        Pixel coordinates ``(u, v)`` with distortion applied; NaN for points behind the camera.
    """
    x, y, z = np.broadcast_arrays(
        np.asarray(x_fwd, dtype=np.float64),
        np.asarray(y_left, dtype=np.float64),
        np.asarray(z_up, dtype=np.float64),
    )
    pts = np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1)
    uv, _ = camera.project(pts)
    return uv


@dataclass(frozen=True)
class BevGrid:
    """A bird's-eye-view raster over the road in the vehicle frame.

    The BEV image looks down with forward up: row 0 is the far edge (``x_max_m``), column 0
    the left edge (``y_max_m``). Cell centres are at ``x_max_m - (row + 0.5) * resolution_m``
    and ``y_max_m - (col + 0.5) * resolution_m``.

    Attributes:
        x_min_m: Nearest forward distance, metres.
        x_max_m: Farthest forward distance, metres.
        y_min_m: Rightmost lateral position (negative = right), metres.
        y_max_m: Leftmost lateral position, metres.
        resolution_m: Cell size, metres per BEV pixel.
    """

    x_min_m: float = 5.0
    x_max_m: float = 60.0
    y_min_m: float = -10.0
    y_max_m: float = 10.0
    resolution_m: float = 0.1

    def __post_init__(self) -> None:
        if self.resolution_m <= 0:
            raise CameraError(f"BEV resolution must be positive, got {self.resolution_m} m")
        if self.x_max_m <= self.x_min_m or self.y_max_m <= self.y_min_m:
            raise CameraError(
                f"empty BEV range x [{self.x_min_m}, {self.x_max_m}] y "
                f"[{self.y_min_m}, {self.y_max_m}] m"
            )

    @property
    def shape(self) -> tuple[int, int]:
        """Return ``(rows, cols)`` of the BEV image."""
        rows = round((self.x_max_m - self.x_min_m) / self.resolution_m)
        cols = round((self.y_max_m - self.y_min_m) / self.resolution_m)
        return max(rows, 1), max(cols, 1)

    def x_centers(self) -> FloatArray:
        """Return the forward distance in metres of each BEV row's centre (far to near)."""
        rows, _ = self.shape
        return self.x_max_m - (np.arange(rows, dtype=np.float64) + 0.5) * self.resolution_m

    def y_centers(self) -> FloatArray:
        """Return the lateral position in metres of each BEV column's centre (left to right)."""
        _, cols = self.shape
        return self.y_max_m - (np.arange(cols, dtype=np.float64) + 0.5) * self.resolution_m

    def to_pixel(self, x_fwd: FloatArray, y_left: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Return fractional BEV ``(col, row)`` of vehicle-frame points (for plotting)."""
        col = (self.y_max_m - np.asarray(y_left, dtype=np.float64)) / self.resolution_m - 0.5
        row = (self.x_max_m - np.asarray(x_fwd, dtype=np.float64)) / self.resolution_m - 0.5
        return col, row

    def extent(self) -> tuple[float, float, float, float]:
        """Return ``(left, right, bottom, top)`` in metres for ``matplotlib.imshow``.

        The horizontal axis is ``y_left`` decreasing to the right, the vertical axis ``x_fwd``.
        """
        return (self.y_max_m, self.y_min_m, self.x_min_m, self.x_max_m)


def bev_maps(camera: CameraModel, grid: BevGrid) -> tuple[FloatArray, FloatArray]:
    """Return per-BEV-cell source pixel maps ``(map_u, map_v)`` (float32-ready, NaN-free).

    Cells behind the camera map to ``-1`` (outside the image).
    """
    xs, ys = np.meshgrid(grid.x_centers(), grid.y_centers(), indexing="ij")
    uv = ground_to_image(camera, xs, ys)
    uv = np.where(np.isfinite(uv), uv, -1.0)
    rows, cols = grid.shape
    return uv[:, 0].reshape(rows, cols), uv[:, 1].reshape(rows, cols)


def warp_to_bev(
    camera: CameraModel,
    image: np.ndarray[Any, np.dtype[Any]],
    grid: BevGrid,
    interpolation: str = "linear",
) -> np.ndarray[Any, np.dtype[Any]]:
    """Resample a camera image onto a :class:`BevGrid` (flat road), for plots.

    Args:
        camera: The camera that took ``image``.
        image: ``(H, W)`` or ``(H, W, C)`` image of the camera's size.
        grid: The BEV raster.
        interpolation: ``linear`` or ``nearest`` (use ``nearest`` for label images).

    Returns:
        The BEV image, shape ``grid.shape`` (+ channels), same dtype; cells outside the camera
        image are 0.

    Raises:
        CameraError: If the image size does not match the camera or the interpolation is unknown.
    """
    import cv2  # late: heavy import

    if image.shape[0] != camera.height or image.shape[1] != camera.width:
        raise CameraError(
            f"image is {image.shape[1]}x{image.shape[0]} but the camera is "
            f"{camera.width}x{camera.height}"
        )
    modes = {"linear": cv2.INTER_LINEAR, "nearest": cv2.INTER_NEAREST}
    if interpolation not in modes:
        raise CameraError(f"interpolation must be one of {sorted(modes)}, got {interpolation!r}")
    map_u, map_v = bev_maps(camera, grid)
    out: np.ndarray[Any, np.dtype[Any]] = cv2.remap(
        image,
        map_u.astype(np.float32),
        map_v.astype(np.float32),
        interpolation=modes[interpolation],
        borderMode=cv2.BORDER_CONSTANT,
        borderValue=0,
    )
    return out
