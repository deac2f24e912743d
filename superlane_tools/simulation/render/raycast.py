"""Exact ray casting of every pixel onto the road height field, with road coordinates (s, l).

The road surface is the height field of :class:`~superlane_tools.simulation.scene.RoadProfile`:
height ``z(s)`` along the reference line, laterally flat. A ray from the camera rises
``q = dz/dx`` metres per metre forward; it first meets the surface at the smallest forward
distance ``x`` where ``q <= (z(x) - z_cam) / (x - x_cam)``. The running maximum of that
right-hand side over the sampled profile is monotone, so the first hit (hidden parts behind a
crest included) is one ``searchsorted`` plus an exact solve inside the piecewise-linear segment;
one Newton step then corrects for the lateral offset on curves (``z`` is a function of ``s``, not
of ``x``). Beyond its last sample the road continues straight and level.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from superlane_tools.simulation.errors import ScenarioError
from superlane_tools.simulation.render._rays import CameraRays
from superlane_tools.simulation.scene import RoadProfile

F32 = NDArray[np.float32]
F64 = NDArray[np.float64]

_TABLE_STEP_M = 0.25
#: Largest pixel footprint reported (metres), at the horizon and crests.
MAX_FOOTPRINT_M = 5.0


class RoadTables(NamedTuple):
    """The reference line resampled on uniform ``x`` and uniform ``s`` grids (float32)."""

    x0: float
    dx: float
    by_x: F32  # (n, 4): s, y, cos(heading), sin(heading) at uniform x
    s0: float
    ds: float
    by_s: F32  # (m, 5): x, y, cos(heading), sin(heading), z at uniform s
    flat: bool
    s_first: float
    s_last: float
    x_cols: tuple[tuple[F32, F32], ...]  # (value, slope per step) of each by_x column
    s_cols: tuple[tuple[F32, F32], ...]  # (value, slope per step) of each by_s column


class RoadHit(NamedTuple):
    """Where the pixel rays of rows ``row0:`` meet the road surface.

    All arrays have shape ``(H - row0, W)``; pixels that miss (sky) have ``hit`` False, infinite
    ``range_m`` and meaningless other values.

    Attributes:
        row0: First image row cast.
        hit: Ray meets the ground.
        x_m: Forward position of the hit, vehicle frame, metres.
        y_m: Lateral position, metres, left positive.
        z_m: Height, metres.
        range_m: Distance from the optical centre, metres.
        s_m: Arc length along the reference line, metres.
        l_m: Lateral offset from the reference line in the road plane, metres, left positive.

    Pixel footprints (metres per pixel) are computed where they are needed, with
    :func:`footprint` (every pixel) or :func:`footprint_at` (a few pixels).
    """

    row0: int
    hit: NDArray[np.bool_]
    x_m: F32
    y_m: F32
    z_m: F32
    range_m: F32
    s_m: F32
    l_m: F32


def road_tables(road: RoadProfile) -> RoadTables:
    """Resample the reference line of ``road`` on uniform grids for fast per-pixel lookups.

    Raises:
        ScenarioError: If the profile has fewer than two samples or ``x_m`` / ``s_m`` is not
            increasing.
    """
    s, x = np.asarray(road.s_m, np.float64), np.asarray(road.x_m, np.float64)
    y, z = np.asarray(road.y_m, np.float64), np.asarray(road.z_m, np.float64)
    hd = np.asarray(road.heading_rad, np.float64)
    if s.size < 2 or not (s.shape == x.shape == y.shape == z.shape == hd.shape):
        raise ScenarioError("road profile needs >= 2 samples of equal-length arrays")
    if np.any(np.diff(x) <= 0) or np.any(np.diff(s) <= 0):
        raise ScenarioError("road profile x_m and s_m must increase strictly")
    # Straight, level continuation far beyond the last sample (the road fades into the haze).
    ext = 600.0
    s_e = np.append(s, s[-1] + ext)
    x_e = np.append(x, x[-1] + ext * np.cos(hd[-1]))
    y_e = np.append(y, y[-1] + ext * np.sin(hd[-1]))
    z_e = np.append(z, z[-1])
    h_e = np.append(hd, hd[-1])
    xs = np.arange(x[0], x_e[-1], _TABLE_STEP_M)
    by_x = np.stack(
        [
            np.interp(xs, x_e, s_e),
            np.interp(xs, x_e, y_e),
            np.cos(np.interp(xs, x_e, h_e)),
            np.sin(np.interp(xs, x_e, h_e)),
        ],
        axis=1,
    )
    ss = np.arange(s[0], s_e[-1], _TABLE_STEP_M)
    by_s = np.stack(
        [
            np.interp(ss, s_e, x_e),
            np.interp(ss, s_e, y_e),
            np.cos(np.interp(ss, s_e, h_e)),
            np.sin(np.interp(ss, s_e, h_e)),
            np.interp(ss, s_e, z_e),
        ],
        axis=1,
    )
    bx32, bs32 = by_x.astype(np.float32), by_s.astype(np.float32)
    return RoadTables(
        x0=float(xs[0]),
        dx=_TABLE_STEP_M,
        by_x=by_x.astype(np.float32),
        s0=float(ss[0]),
        ds=_TABLE_STEP_M,
        by_s=by_s.astype(np.float32),
        flat=bool(np.all(np.abs(z) < 1e-4)),
        s_first=float(s[0]),
        s_last=float(s[-1]),
        x_cols=_columns(bx32),
        s_cols=_columns(bs32),
    )


def _columns(table: F32) -> tuple[tuple[F32, F32], ...]:
    out = []
    for c in range(table.shape[1]):
        col = np.ascontiguousarray(table[:, c])
        out.append((col, np.diff(col, append=col[-1:]).astype(np.float32)))
    return tuple(out)


def _lerp(cols: tuple[tuple[F32, F32], ...], t0: float, dt: float, value: F32) -> list[F32]:
    """Linearly interpolate uniform table columns at ``value`` (extrapolating at the ends).

    The tables reach far beyond the visible road, where the road is straight, so the
    extrapolation is exact there.
    """
    n = cols[0][0].size
    fi = value - np.float32(t0)
    fi *= np.float32(1.0 / dt)
    i = np.clip(fi, 0, n - 2).astype(np.intp)  # intp: np.take converts other index types
    fi -= i.astype(np.float32)  # the fraction within the table step
    out = []
    for val, slope in cols:
        v = np.take(slope, i)
        v *= fi
        v += np.take(val, i)
        out.append(v)
    return out


def road_coordinates(
    tables: RoadTables, x: F32, y: F32, with_z: bool = True
) -> tuple[F32, F32, F32 | None]:
    """Map vehicle-frame ground points to road coordinates.

    Args:
        tables: Resampled reference line.
        x: Forward positions, metres.
        y: Lateral positions, metres, left positive.
        with_z: Also return the surface height (else None).

    Returns:
        Arc length ``s`` (m), lateral offset ``l`` (m, left positive) and the surface height
        ``z(s)`` (m).
    """
    cols_x = (tables.x_cols[0], tables.x_cols[1], tables.x_cols[3])
    if x.ndim == 2 and x.shape[1] > 1 and x.strides[1] == 0:
        # Constant along rows (camera without roll): the first lookup is per row.
        s0, yr, s_h = (a[:, :1] for a in _lerp(cols_x, tables.x0, tables.dx, x[:, :1]))
    else:
        s0, yr, s_h = _lerp(cols_x, tables.x0, tables.dx, x)
    s1 = y - yr
    s1 *= s_h
    s1 += s0
    cols_s = tables.s_cols if with_z else tables.s_cols[:4]
    res = _lerp(cols_s, tables.s0, tables.ds, s1)
    xr2, yr2, c2, s2 = res[:4]
    ex = x - xr2
    ey = y - yr2
    s_m = ex * c2
    s_m += s1
    s_m += ey * s2
    l_m = ey * c2
    l_m -= ex * s2
    return s_m, l_m, (res[4] if with_z else None)


def _first_hit_x(tables: RoadTables, origin: F64, q: F32) -> F32:
    """Return the forward distance (m) where rays of rise ``q`` (m/m) first meet the surface."""
    ox, oz = float(origin[0]), float(origin[2])
    if tables.flat:
        with np.errstate(divide="ignore"):
            x = np.where(q < 0, ox - oz / np.minimum(q, -1e-9), np.inf)
        return x.astype(np.float32)
    # Height as a function of x along the reference line, sampled finely.
    xs = tables.by_s[:, 0].astype(np.float64)
    zs = tables.by_s[:, 4].astype(np.float64)
    keep = xs > ox + 0.5
    xs, zs = xs[keep], zs[keep]
    f_k = (zs - oz) / (xs - ox)
    m_k = np.maximum.accumulate(f_k)
    q64 = q.astype(np.float64)
    k = np.searchsorted(m_k, q64, side="left")
    n = xs.size
    kk = np.clip(k, 1, n - 1)
    x0, z0 = xs[kk - 1], zs[kk - 1]
    g = (zs[kk] - z0) / (xs[kk] - x0)
    with np.errstate(divide="ignore", invalid="ignore"):
        x_seg = (z0 - g * x0 - oz + q64 * ox) / (q64 - g)
        x_near = ox + (zs[0] - oz) / np.minimum(q64, -1e-9)
        x_far = ox + (zs[-1] - oz) / np.minimum(q64, -1e-9)
    x = np.where(k == 0, x_near, x_seg)
    beyond = k >= n
    x = np.where(beyond, np.where((q64 < 0) & (x_far > xs[-1]), x_far, np.inf), x)
    x = np.where(np.isfinite(q64), x, np.inf)
    return x.astype(np.float32)


def cast_road(rays: CameraRays, tables: RoadTables) -> RoadHit:
    """Intersect the pixel rays with the road height field (see the module docstring)."""
    origin = rays.origin
    ox, oy, oz = (np.float32(v) for v in origin)
    # Highest rise of any ray that can still hit the surface.
    if tables.flat:
        q_max = 0.0
    else:
        xs = tables.by_s[:, 0].astype(np.float64)
        zs = tables.by_s[:, 4].astype(np.float64)
        keep = xs > origin[0] + 0.5
        q_max = max(0.0, float(np.max((zs[keep] - origin[2]) / (xs[keep] - origin[0]))))
    rows = np.nonzero(rays.row_min_slope < q_max)[0]
    h, _w = rays.slope_z.shape
    row0 = int(rows[0]) if rows.size else h
    q = rays.slope_z[row0:]
    if rays.per_row:
        x = np.broadcast_to(_first_hit_x(tables, origin, q[:, 0])[:, None], q.shape)
    else:
        x = _first_hit_x(tables, origin, q)
    hit = np.isfinite(x)
    x = np.where(hit, x, np.float32(1e6)).astype(np.float32)
    ay = rays.slope_y[row0:]
    y = oy + (x - ox) * ay
    s, l_m, zsurf = road_coordinates(tables, x, y, with_z=not tables.flat)
    if not tables.flat and zsurf is not None:
        # Newton step: the surface height is z(s); the first guess used z along the reference x.
        zray = oz + (x - ox) * q
        (z_ahead,) = _lerp(tables.s_cols[4:], tables.s0, tables.ds, s + np.float32(1.0))
        grade = z_ahead - zsurf
        denom = np.where(np.abs(grade - q) < 1e-4, np.float32(-1e-4), grade - q)
        x = np.where(hit, x + (zray - zsurf) / denom, x).astype(np.float32)
        y = oy + (x - ox) * ay
        s, l_m, _ = road_coordinates(tables, x, y, with_z=False)
    z = oz + (x - ox) * q
    hit &= np.isfinite(s) & np.isfinite(l_m) & (np.abs(l_m) < 1e4)
    s = np.where(hit, s, np.float32(tables.s_first)).astype(np.float32)
    l_m = np.where(hit, l_m, np.float32(1e4)).astype(np.float32)
    rng = np.where(hit, (x - ox) * rays.range_per_x[row0:], np.float32(np.inf)).astype(np.float32)
    return RoadHit(row0, hit, x, y, z.astype(np.float32), rng, s, l_m)


def footprint_at(a: F32, hit: NDArray[np.bool_], idx: NDArray[np.intp]) -> F32:
    """Return :func:`footprint` of ``a`` at the flat indices ``idx`` only (same values)."""
    rows, cols = a.shape
    flat = a.reshape(-1)
    r, c = np.divmod(idx, cols)
    cu = np.where(c < cols - 1, idx, idx - 1)  # the last column reuses its left difference
    fp = np.abs(flat[cu + 1] - flat[cu])
    if rows > 1:
        rv = np.where(r < rows - 1, idx, idx - cols)
        fp += np.abs(flat[rv + cols] - flat[rv])
    fp = np.where(hit.reshape(-1)[idx], fp, np.float32(MAX_FOOTPRINT_M))
    out: F32 = np.clip(fp, 1e-4, MAX_FOOTPRINT_M).astype(np.float32)
    return out


def footprint(a: F32, hit: NDArray[np.bool_]) -> F32:
    """Return |da/du| + |da/dv| per pixel (metres per pixel), clipped, from forward differences.

    Args:
        a: A road coordinate per pixel (``s_m`` or ``l_m`` of a :class:`RoadHit`), metres.
        hit: Pixels whose ray meets the ground (others get the largest footprint).
    """
    fp = np.zeros_like(a)
    du = np.abs(np.diff(a, axis=1))
    fp[:, :-1] += du
    fp[:, -1] += du[:, -1]
    if a.shape[0] > 1:
        dv = np.abs(np.diff(a, axis=0))
        fp[:-1] += dv
        fp[-1] += dv[-1]
    fp = np.where(hit, fp, np.float32(MAX_FOOTPRINT_M))
    return np.clip(fp, 1e-4, MAX_FOOTPRINT_M).astype(np.float32)
