"""Tunnel interior: walls following the road edges, a ceiling and a row of lamps."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from superlane_tools.hierarchy import LEAF_IDS
from superlane_tools.simulation.render._rays import CameraRays
from superlane_tools.simulation.render.raycast import RoadHit, RoadTables, road_coordinates
from superlane_tools.simulation.render.road_shading import fmod_pos
from superlane_tools.simulation.scene import RoadProfile

F32 = NDArray[np.float32]

WALL = LEAF_IDS["building_wall_fence"]
_CEILING_M = 5.2
_WALL_GAP_M = 0.4
_LAMP_PERIOD_M = 10.0


def _first_below(f: NDArray[np.float64], xs: NDArray[np.float64], q: F32) -> F32:
    """Return the first ``x`` (m) where ``f(x) <= q`` (running minimum, interpolated), or inf."""
    m = np.minimum.accumulate(f)
    x = np.interp(-q.astype(np.float64), -m, xs, left=np.inf, right=np.inf)
    return np.where(q >= m[-1], x, np.inf).astype(np.float32)


def draw_tunnel(
    img: F32,
    labels: NDArray[np.uint8],
    range_m: F32,
    ground_mask: NDArray[np.bool_],
    rays: CameraRays,
    tables: RoadTables,
    road: RoadProfile,
    hit: RoadHit,
) -> None:
    """Draw tunnel walls, ceiling and lamps over sky and far ground pixels, in place."""
    ox, oy, oz = (float(v) for v in rays.origin)
    bx = tables.by_s
    xs = bx[:, 0].astype(np.float64)
    keep = xs > ox + 0.5
    xs = xs[keep]
    yr = bx[keep, 1].astype(np.float64)
    cos_h = np.maximum(bx[keep, 2].astype(np.float64), 0.2)
    zr = bx[keep, 4].astype(np.float64)
    dx = xs - ox
    left = (yr + (road.left_edge_m + _WALL_GAP_M) / cos_h - oy) / dx
    right = (yr + (road.right_edge_m - _WALL_GAP_M) / cos_h - oy) / dx
    ceil = (zr + _CEILING_M - oz) / dx
    py, q = rays.slope_y, rays.slope_z
    q_fin = np.where(np.isfinite(q), q, np.float32(1e3))
    x_left = _first_below(left, xs, py)
    x_right = _first_below(-right, xs, -py)
    x_ceil = _first_below(ceil, xs, q_fin)
    x_t = np.minimum(np.minimum(x_left, x_right), x_ceil)
    x_ground = np.full(q.shape, np.inf, np.float32)
    x_ground[hit.row0 :] = np.where(hit.hit, hit.x_m, np.inf)
    mask = np.isfinite(x_t) & (x_t < x_ground)
    if not np.any(mask):
        return
    x = x_t[mask]
    y = np.float32(oy) + (x - np.float32(ox)) * py[mask]
    z = np.float32(oz) + (x - np.float32(ox)) * q_fin[mask]
    s, l_m, zs = road_coordinates(tables, x, y)
    assert zs is not None
    is_ceiling = x_ceil[mask] <= np.minimum(x_left, x_right)[mask]
    h_wall = z - zs
    tile = (fmod_pos(s, 2.5) < 0.05) | (fmod_pos(h_wall, 1.0) < 0.04)
    wall_col = np.where(h_wall < 1.1, np.float32(95.0), np.float32(150.0)) * (
        np.float32(1.0) - np.float32(0.25) * tile
    )
    lamp = (fmod_pos(s, _LAMP_PERIOD_M) < 3.0) & (np.abs(l_m) < 0.35)
    val = np.where(is_ceiling, np.float32(60.0), wall_col)
    val = np.where(is_ceiling & lamp, np.float32(255.0), val)
    col = np.stack([val * 0.9, val * 0.97, val], axis=1)
    col[is_ceiling & lamp] = (200.0, 235.0, 255.0)
    # Sodium-ish lamp light on the walls and ceiling fades with distance.
    rng = (x - np.float32(ox)) * rays.range_per_x[mask]
    col *= (np.float32(0.55) + np.float32(0.45) * np.exp(-rng / np.float32(60.0)))[:, None]
    img[mask] = col
    labels[mask] = WALL
    range_m[mask] = rng
    ground_mask[mask] = False
