"""Slope compensation (SUPER paper, section III-B, Eq. 5-10) with pluggable road models.

Flat-ground IPM puts every pixel where its ray meets the plane ``z = 0``. On a sloped road the
ray meets the road earlier (uphill) or later (downhill), so parallel lanes fan out in the
bird's-eye view. Every point on the ray from the camera through the flat-ground point
``(x~, y~)`` is ``s * (x~, y~, -h)`` relative to the camera, for a scale ``s > 0``; the true road
point is the first ``s`` where the ray meets the road surface ``z = f_z(x)``:

    -s h = f_z(s x~)                                   (paper Eq. 8, with y_paper = x here)
    x = s x~,  y = s y~                                (paper Eq. 7, 9)

Names follow this package, not the paper: the paper's forward ``y`` is ``x`` here, its lateral
``x`` is ``y`` (left positive), and ``f_z`` is the road height relative to the camera, metres.
Forward and lateral coordinates are measured from the road point below the camera (the vehicle
frame with the default extrinsics ``x_m = y_m = 0``; see :func:`compensate_points` otherwise).

For the linear road ``f_z = b x - h`` (``b`` = grade, rise over run; positive uphill) the scale
has the closed form of Eq. 10, ``s = 1 / (1 + b x~ / h)``, i.e.

    x = x~ / (1 + b x~ / h),   y = y~ / (1 + b x~ / h).

(The sign differs from writing ``1 - b x~ / h``: with ``z`` up and ``b > 0`` uphill the ray
meets the road *before* the flat-ground point.) Points whose ray never meets the road (a
downhill grade steeper than the ray) come back as NaN.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np

from superlane_tools.camera.errors import CameraError
from superlane_tools.camera.model import CameraModel, FloatArray

ParamsLike = Sequence[float] | FloatArray
"""Road-model parameters: a short sequence of floats (e.g. ``(b,)`` or ``(b, c)``)."""


@runtime_checkable
class RoadModel(Protocol):
    """A road-surface profile along the driving direction, for slope compensation.

    Attributes:
        height_m: Camera height above the road at the camera's foot point, metres.
        n_params: Number of free parameters the model takes.
    """

    height_m: float
    n_params: int

    def f_z(self, x_fwd_m: FloatArray, params: ParamsLike) -> FloatArray:
        """Return the road height relative to the camera (metres, negative = below) at ``x``."""
        ...

    def ray_scale(self, x_flat_m: FloatArray, params: ParamsLike) -> FloatArray:
        """Return ``s`` such that the ray to flat point ``x~`` meets the road at ``s * x~``.

        NaN where the ray does not meet the road ahead.
        """
        ...


def _param(params: ParamsLike, n: int, model: str) -> tuple[float, ...]:
    values = tuple(float(p) for p in np.asarray(params, dtype=np.float64).ravel())
    if len(values) != n:
        raise CameraError(f"{model} takes {n} parameter(s), got {len(values)}")
    return values


def compensate_linear(
    x_flat_m: FloatArray, y_flat_m: FloatArray, grade: float, height_m: float
) -> tuple[FloatArray, FloatArray]:
    """Correct flat-ground IPM points for a constant road grade (paper Eq. 10), vectorised.

    This is the hot path of the lane fit (called for every candidate grade), so it allocates
    only a few arrays and has no Python loops.

    Args:
        x_flat_m: Flat-ground forward distances from the camera foot point, metres.
        y_flat_m: Flat-ground lateral offsets (left positive), metres.
        grade: Road grade ``b`` = dz/dx (positive uphill), dimensionless.
        height_m: Camera height above the road, metres.

    Returns:
        The true forward and lateral coordinates on the sloped road, metres; NaN where the ray
        misses the road.
    """
    x = np.asarray(x_flat_m, dtype=np.float64)
    denom = 1.0 + (grade / height_m) * x
    with np.errstate(divide="ignore", invalid="ignore"):
        scale = np.where(denom > 0.0, 1.0 / denom, np.nan)
    return x * scale, np.asarray(y_flat_m, dtype=np.float64) * scale


@dataclass(frozen=True)
class LinearRoad:
    """A road of constant grade: ``f_z(x) = b x - h`` (paper Eq. 10), params ``(b,)``.

    Attributes:
        height_m: Camera height above the road, metres.
    """

    height_m: float
    n_params: int = 1

    def f_z(self, x_fwd_m: FloatArray, params: ParamsLike) -> FloatArray:
        """Return ``b x - h`` in metres."""
        (b,) = _param(params, 1, "LinearRoad")
        out: FloatArray = b * np.asarray(x_fwd_m, dtype=np.float64) - self.height_m
        return out

    def ray_scale(self, x_flat_m: FloatArray, params: ParamsLike) -> FloatArray:
        """Return ``1 / (1 + b x~ / h)``; NaN where the ray misses the road."""
        (b,) = _param(params, 1, "LinearRoad")
        denom = 1.0 + (b / self.height_m) * np.asarray(x_flat_m, dtype=np.float64)
        with np.errstate(divide="ignore", invalid="ignore"):
            out: FloatArray = np.where(denom > 0.0, 1.0 / denom, np.nan)
        return out


@dataclass(frozen=True)
class QuadraticRoad:
    """A road with grade and vertical curvature: ``f_z(x) = b x + c x^2 - h``, params ``(b, c)``.

    ``c`` (1/m) > 0 is a sag (valley), ``c`` < 0 a crest. The ray meets the road where
    ``c x~^2 s^2 + (b x~ + h) s - h = 0``; the first positive root is taken in the
    cancellation-free form ``s = 2 h / (B + sqrt(B^2 + 4 c x~^2 h))`` with ``B = b x~ + h``.

    Attributes:
        height_m: Camera height above the road, metres.
    """

    height_m: float
    n_params: int = 2

    def f_z(self, x_fwd_m: FloatArray, params: ParamsLike) -> FloatArray:
        """Return ``b x + c x^2 - h`` in metres."""
        b, c = _param(params, 2, "QuadraticRoad")
        x = np.asarray(x_fwd_m, dtype=np.float64)
        out: FloatArray = (b + c * x) * x - self.height_m
        return out

    def ray_scale(self, x_flat_m: FloatArray, params: ParamsLike) -> FloatArray:
        """Return the first positive ray scale; NaN where the ray misses the road."""
        b, c = _param(params, 2, "QuadraticRoad")
        h = self.height_m
        x = np.asarray(x_flat_m, dtype=np.float64)
        big_b = b * x + h
        disc = big_b * big_b + 4.0 * c * h * x * x
        with np.errstate(divide="ignore", invalid="ignore"):
            denom = big_b + np.sqrt(np.where(disc >= 0.0, disc, np.nan))
            out: FloatArray = np.where(denom > 0.0, 2.0 * h / denom, np.nan)
        return out


def ray_scale_numeric(
    model: RoadModel,
    x_flat_m: FloatArray,
    params: ParamsLike,
    max_scale: float = 50.0,
    n_grid: int = 256,
    n_bisect: int = 60,
) -> FloatArray:
    """Solve paper Eq. 8 for any road model by bracketing and bisection, vectorised.

    Finds the first ``s`` in ``(0, max_scale]`` where the ray ``s * (x~, -h)`` reaches the road
    ``f_z``; use it for road models without a closed form (and to check those with one).

    Args:
        model: The road model (only ``f_z`` and ``height_m`` are used).
        x_flat_m: Flat-ground forward distances, metres.
        params: Road-model parameters.
        max_scale: Largest ray scale searched.
        n_grid: Geometric bracketing grid size over ``(0, max_scale]``.
        n_bisect: Bisection steps (60 reach double precision).

    Returns:
        The ray scale per point; NaN where the ray does not meet the road within ``max_scale``.
    """
    x = np.asarray(x_flat_m, dtype=np.float64).ravel()
    h = model.height_m
    grid = np.concatenate([[0.0], np.geomspace(1e-3, max_scale, n_grid)])

    def gap(s: FloatArray, xs: FloatArray) -> FloatArray:
        # > 0 once the ray is at or below the road surface.
        out: FloatArray = model.f_z(s * xs, params) + s * h
        return out

    g = gap(grid[None, :], x[:, None])  # (N, G)
    hit = g >= 0.0
    found = hit.any(axis=1)
    first = np.argmax(hit, axis=1)
    hi = grid[first]
    lo = grid[np.maximum(first - 1, 0)]
    for _ in range(n_bisect):
        mid = 0.5 * (lo + hi)
        above = gap(mid, x) >= 0.0
        hi = np.where(above, mid, hi)
        lo = np.where(above, lo, mid)
    out: FloatArray = np.where(found & (first > 0), hi, np.nan)
    return out.reshape(np.shape(x_flat_m))


def compensate(
    model: RoadModel, x_flat_m: FloatArray, y_flat_m: FloatArray, params: ParamsLike
) -> tuple[FloatArray, FloatArray]:
    """Map flat-ground IPM points onto the road surface of ``model`` (paper Eq. 7-9).

    Args:
        model: The road model.
        x_flat_m: Flat-ground forward distances from the camera foot point, metres.
        y_flat_m: Flat-ground lateral offsets (left positive), metres.
        params: Road-model parameters.

    Returns:
        True forward and lateral coordinates, metres; NaN where the ray misses the road.
    """
    scale = model.ray_scale(x_flat_m, params)
    return (
        np.asarray(x_flat_m, dtype=np.float64) * scale,
        np.asarray(y_flat_m, dtype=np.float64) * scale,
    )


def road_height(model: RoadModel, x_fwd_m: FloatArray, params: ParamsLike) -> FloatArray:
    """Return the road height above the flat plane ``z = 0`` at ``x``, metres (``f_z + h``)."""
    out: FloatArray = model.f_z(x_fwd_m, params) + model.height_m
    return out


def compensate_points(
    camera: CameraModel, xy_flat_m: FloatArray, model: RoadModel, params: ParamsLike
) -> FloatArray:
    """Compensate ``(N, 2)`` vehicle-frame flat-ground points of ``camera`` for the road model.

    Handles a camera mounted off the vehicle origin (``x_m``, ``y_m``) by working relative to
    the camera's foot point. ``model.height_m`` should equal the camera height.

    Returns:
        ``(N, 2)`` corrected vehicle-frame ``(x forward, y left)``, metres.
    """
    pts = np.asarray(xy_flat_m, dtype=np.float64).reshape(-1, 2)
    x0, y0 = camera.extrinsics.x_m, camera.extrinsics.y_m
    x, y = compensate(model, pts[:, 0] - x0, pts[:, 1] - y0, params)
    return np.stack([x + x0, y + y0], axis=1)
