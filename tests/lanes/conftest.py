"""Fixtures of the lane tests: render synthetic lane masks from known 3D geometry."""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
import pytest

from superlane_tools.camera import CameraModel, Extrinsics, Intrinsics

Renderer = Callable[..., tuple[np.ndarray, np.ndarray]]


def make_camera(height_m: float = 1.5, pitch_rad: float = 0.06, focal_px: float = 1000.0):
    """Return a 1280x720 pinhole camera."""
    return CameraModel(
        Intrinsics(1280, 720, focal_px, focal_px, 639.5, 359.5),
        Extrinsics(height_m=height_m, pitch_rad=pitch_rad),
    )


def render_lanes(
    camera: CameraModel,
    offsets: Sequence[float],
    a1: float,
    a2: float,
    slope: float,
    x_range: tuple[float, float] = (4.0, 60.0),
    marking_m: float = 0.15,
    dashed: bool = False,
) -> tuple[np.ndarray, np.ndarray]:
    """Return ``(lane_uv, road_uv)`` pixels of parallel lines on the road ``z = slope * x``."""
    xs = np.arange(x_range[0], x_range[1], 0.02)
    if dashed:
        xs = xs[np.mod(xs, 12.0) < 3.0]
    lat = np.linspace(-marking_m / 2, marking_m / 2, 5)
    pix = []
    for off in offsets:
        x = np.repeat(xs, lat.size)
        y = off + a1 * x + a2 * x * x + np.tile(lat, xs.size)
        uv, front = camera.project(np.stack([x, y, slope * x], axis=1))
        pix.append(uv[front])
    lane = np.unique(np.round(np.concatenate(pix)).astype(np.int64), axis=0)
    inside = (
        (lane[:, 0] >= 0)
        & (lane[:, 0] < camera.width)
        & (lane[:, 1] >= 0)
        & (lane[:, 1] < camera.height)
    )
    lane = lane[inside].astype(np.float64)
    # Road: a coarse grid between the outermost lines.
    xr = np.arange(x_range[0], x_range[1], 0.5)
    yr = np.linspace(min(offsets), max(offsets), 25)
    gx, gy = np.meshgrid(xr, yr)
    gx, gy = gx.ravel(), gy.ravel()
    uv, front = camera.project(np.stack([gx, gy + a1 * gx + a2 * gx * gx, slope * gx], axis=1))
    road = np.round(uv[front])
    ok = (road[:, 0] >= 0) & (road[:, 0] < camera.width) & (road[:, 1] >= 0)
    ok &= road[:, 1] < camera.height
    return lane, road[ok]


@pytest.fixture
def renderer() -> Renderer:
    """Return :func:`render_lanes`."""
    return render_lanes


@pytest.fixture
def camera_factory() -> Callable[..., CameraModel]:
    """Return :func:`make_camera`."""
    return make_camera
