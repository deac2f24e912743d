"""Ground pixels: hierarchical labels and colours of road, markings, shoulders and terrain.

Everything is evaluated in road coordinates ``(s, l)`` from :mod:`.raycast`, so markings land
exactly where the lines are and textures stay fixed on the road while the car moves. Paint is
anti-aliased with the pixel footprint in metres; labels use the pixel centre (widened to one
pixel where a line is thinner than a pixel, so far lines stay connected in the masks).
"""

from __future__ import annotations

import itertools
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from superlane_tools.hierarchy import LEAF_IDS
from superlane_tools.simulation.render.raycast import RoadHit
from superlane_tools.simulation.render.textures import (
    COARSE_TEXEL_M,
    FINE_TEXEL_M,
    RoadTextures,
)
from superlane_tools.simulation.scene import LaneLine, LineColor, LineStyle, RoadProfile

F32 = NDArray[np.float32]
U8 = NDArray[np.uint8]

ROAD = LEAF_IDS["road"]
TERRAIN = LEAF_IDS["terrain_ground"]
SIDEWALK = LEAF_IDS["sidewalk_curb"]
CROSSWALK = LEAF_IDS["crosswalk"]
STOP_LINE = LEAF_IDS["stop_line"]
#: Leaf ids of the drivable surface (the corridor may only cover these).
DRIVABLE_IDS = (ROAD, CROSSWALK, LEAF_IDS["other_marking"], *range(13, 20))

_DOUBLE_GAP_M = 0.15
_STOP_LINE_WIDTH_M = 0.45
_ZEBRA_STRIPE_M = 0.5


class Palette(NamedTuple):
    """Base colours (BGR, 0..255 floats) of the ground, possibly randomised."""

    asphalt: tuple[float, float, float]
    concrete: tuple[float, float, float]
    white_paint: tuple[float, float, float]
    yellow_paint: tuple[float, float, float]
    grass: tuple[float, float, float]
    dirt: tuple[float, float, float]
    sidewalk: tuple[float, float, float]
    seam: tuple[float, float, float]


DEFAULT_PALETTE = Palette(
    asphalt=(92.0, 92.0, 96.0),
    concrete=(150.0, 152.0, 155.0),
    white_paint=(228.0, 230.0, 230.0),
    yellow_paint=(40.0, 175.0, 215.0),
    grass=(60.0, 112.0, 92.0),
    dirt=(95.0, 118.0, 130.0),
    sidewalk=(165.0, 168.0, 170.0),
    seam=(30.0, 30.0, 32.0),
)


class Ground(NamedTuple):
    """Shaded ground of rows ``hit.row0:``.

    Attributes:
        color: ``(R, W, 3)`` float32 BGR before lighting, haze and sensor effects.
        labels: ``(R, W)`` leaf ids (0 where the ray misses the ground).
        gloss: ``(R, W)`` specular weight 0..1 (wet asphalt, tar seams) for reflections.
    """

    color: F32
    labels: U8
    gloss: F32


def line_label(line: LaneLine) -> int:
    """Return the hierarchy leaf id of a painted longitudinal line."""
    if line.style is LineStyle.DOUBLE:
        return LEAF_IDS["double_yellow"] if line.color is LineColor.YELLOW else 13
    if line.color is LineColor.YELLOW:
        return LEAF_IDS[
            "dividing_yellow_dashed" if line.style is LineStyle.DASHED else "dividing_yellow_solid"
        ]
    return LEAF_IDS[
        "dividing_white_dashed" if line.style is LineStyle.DASHED else "dividing_white_solid"
    ]


def line_offset(line: LaneLine, s: F32) -> F32 | np.float32:
    """Return the line centre's lateral offset (m) at ``s`` (a scalar when it has no taper)."""
    if np.isnan(line.taper_start_s_m) or line.taper_length_m <= 0:
        return np.float32(line.offset_m)
    return line.offset_at(s.astype(np.float64)).astype(np.float32)


def _stroke(d: F32, half_w: float, foot: F32) -> tuple[F32, NDArray[np.bool_]]:
    """Return anti-aliased coverage and the label mask of a stroke at distance ``d`` (m)."""
    cov = np.clip((np.float32(half_w) - d) / foot + np.float32(0.5), 0.0, 1.0)
    lab = d < np.maximum(np.float32(half_w), np.float32(0.5) * foot)
    return cov, lab


def fmod_pos(a: F32, period: float) -> F32:
    """Return ``a`` modulo ``period`` in ``[0, period)`` (faster than ``np.mod`` for float32)."""
    p = np.float32(period)
    out: F32 = a - np.floor(a * np.float32(1.0 / period)) * p
    return out


def _in_ranges(s: F32, ranges: tuple[tuple[float, float], ...]) -> NDArray[np.bool_]:
    out = np.zeros(s.shape, bool)
    for a, b in ranges:
        out |= (s >= a) & (s < b)
    return out


def _tex_levels(foot: F32, texel_m: float, n_levels: int) -> NDArray[np.int32]:
    """Return the mip level per row (from the footprint at the centre column)."""
    rows = foot[:, foot.shape[1] // 2] / (2.0 * texel_m)
    lev = np.floor(np.log2(np.maximum(rows, 1.0))).astype(np.int32)
    out: NDArray[np.int32] = np.clip(lev, 0, n_levels - 1).astype(np.int32)
    return out


def _sample_mip(mips: F32, texel_m: float, a: F32, b: F32, levels: NDArray[np.int32]) -> F32:
    """Sample a mip chain at road coordinates ``a`` (along) and ``b`` (across), per-row level."""
    n, h, w = mips.shape
    ia = (a * np.float32(1.0 / texel_m)).astype(np.int32) & (w - 1)
    ib = (b * np.float32(1.0 / texel_m)).astype(np.int32) & (h - 1)
    lev = np.broadcast_to(levels[:, None], a.shape)
    out: F32 = mips.reshape(n * h, w)[lev * h + ib, ia]
    return out


def shade_ground(
    hit: RoadHit,
    road: RoadProfile,
    tex: RoadTextures,
    palette: Palette,
    cracks: float,
    tar_seams: float,
    wet: float,
) -> Ground:
    """Label and colour the ground pixels of ``hit`` (see the module docstring).

    Args:
        hit: Ray-cast road coordinates of the rows below the horizon.
        road: The road profile (lines, edges, crosswalks, stop lines).
        tex: Textures of this world.
        palette: Base colours.
        cracks: Crack and patch density 0..1.
        tar_seams: Tar-seam (sealant line) density 0..1.
        wet: Wetness 0..1 (darkens the surface, raises gloss).
    """
    s, l_m, valid = hit.s_m, hit.l_m, hit.hit
    shape = s.shape
    on_road = valid & (l_m <= road.left_edge_m) & (l_m >= road.right_edge_m)
    labels = np.where(valid, np.uint8(TERRAIN), np.uint8(0)).astype(np.uint8)
    labels[on_road] = ROAD
    if road.sidewalk_m > 0:
        side = (
            valid
            & ~on_road
            & (l_m <= road.left_edge_m + road.sidewalk_m)
            & (l_m >= road.right_edge_m - road.sidewalk_m)
        )
        labels[side] = SIDEWALK
    else:
        side = np.zeros(shape, bool)

    # --- surface colour -------------------------------------------------------------------
    lev = _tex_levels(hit.foot_l_m, FINE_TEXEL_M, tex.fine.shape[0])
    grain = _sample_mip(tex.fine, FINE_TEXEL_M, s, l_m, lev)
    ic = (s * np.float32(1.0 / COARSE_TEXEL_M)).astype(np.int32) & 255
    jc = (l_m * np.float32(1.0 / COARSE_TEXEL_M)).astype(np.int32) & 255
    blotch = tex.coarse[jc, ic]
    surf = palette.concrete if road.surface == "concrete" else palette.asphalt
    shade = np.float32(1.0) + np.float32(0.07) * grain + np.float32(0.06) * blotch
    # Tyre tracks: darker (polished) wheel paths and an oil strip in each lane's centre.
    offsets = sorted(ln.offset_m for ln in road.lines)
    prof_l = np.arange(-40.0, 40.0, 0.02, dtype=np.float32)
    prof = np.ones_like(prof_l)
    for a, b in itertools.pairwise(offsets):
        c = 0.5 * (a + b)
        for wheel in (-0.85, 0.85):
            prof -= 0.07 * np.exp(-(((prof_l - c - wheel) / 0.35) ** 2))
        prof -= 0.05 * np.exp(-(((prof_l - c) / 0.25) ** 2))
    if road.surface == "concrete":  # longitudinal slab joints under the lines, dark hairlines
        for o in offsets:
            prof -= 0.25 * np.exp(-(((prof_l - o - 0.12) / 0.02) ** 2))
    li = np.clip(((l_m + 40.0) * 50.0).astype(np.int32), 0, prof_l.size - 1)
    shade *= prof[li]
    if road.surface == "concrete":  # transverse slab joints every 4.6 m
        jm = fmod_pos(s, 4.6)
        joint = np.clip(np.float32(0.03) / hit.foot_s_m, 0.0, 1.0) * (jm < 0.03 + hit.foot_s_m)
        shade *= np.float32(1.0) - np.float32(0.25) * joint
    gloss = np.zeros(shape, np.float32)
    if cracks > 0:
        ic4 = (s * np.float32(4.0 / COARSE_TEXEL_M)).astype(np.int32) & 255
        jc4 = (l_m * np.float32(4.0 / COARSE_TEXEL_M)).astype(np.int32) & 255
        crack = tex.cracks[jc4, ic4] * np.float32(min(1.0, cracks * 1.5))
        crack *= np.clip(np.float32(0.05) / hit.foot_l_m, 0.0, 1.0)
        patch = (blotch > np.float32(2.2 - 1.2 * cracks)).astype(np.float32)
        shade *= (np.float32(1.0) - np.float32(0.45) * crack) * (
            np.float32(1.0) - np.float32(0.12) * patch
        )
    color = np.empty((*shape, 3), np.float32)
    for ch in range(3):
        color[..., ch] = surf[ch] * shade
    if tar_seams > 0:
        i2 = (s * np.float32(1.5 / COARSE_TEXEL_M)).astype(np.int32) & 255
        j2 = (l_m * np.float32(1.5 / COARSE_TEXEL_M)).astype(np.int32) & 255
        seam = tex.seams[j2, i2] * np.float32(min(1.0, tar_seams))
        seam *= np.clip(np.float32(0.04) / hit.foot_l_m, 0.0, 1.0) * on_road
        _blend(color, seam, palette.seam)
        gloss = np.maximum(gloss, seam)

    # --- terrain and sidewalks ------------------------------------------------------------
    off_road = valid & ~on_road
    if np.any(off_road):
        glev = _tex_levels(hit.foot_l_m, 4 * FINE_TEXEL_M, tex.grass.shape[0])
        g = _sample_mip(tex.grass, 4 * FINE_TEXEL_M, s, l_m, glev)
        edge_d = np.maximum(l_m - np.float32(road.left_edge_m), np.float32(road.right_edge_m) - l_m)
        dirt_w = np.clip(np.float32(1.6) - edge_d, 0.0, 1.0)  # gravel strip next to the asphalt
        mix = np.clip(np.float32(0.5) + np.float32(0.35) * blotch + dirt_w, 0.0, 1.0)
        tshade = np.float32(1.0) + np.float32(0.18) * g
        for ch in range(3):
            terr = (palette.grass[ch] * (1 - mix) + palette.dirt[ch] * mix) * tshade
            side_c = palette.sidewalk[ch] * (np.float32(1.0) + np.float32(0.05) * grain)
            color[..., ch] = np.where(off_road, np.where(side, side_c, terr), color[..., ch])

    # --- painted lines --------------------------------------------------------------------
    in_view = valid & (s >= road.s_m[0]) & (s <= road.s_m[-1])
    crosswalk = _in_ranges(s, road.crosswalks_s_m) if road.crosswalks_s_m else None
    for line in road.lines:
        paint_col = palette.yellow_paint if line.color is LineColor.YELLOW else palette.white_paint
        off = line_offset(line, s)
        d = np.abs(l_m - off)
        hw = 0.5 * line.width_m
        if line.style is LineStyle.DOUBLE:
            sep = hw + 0.5 * _DOUBLE_GAP_M
            d = np.abs(d - np.float32(sep))
        cov, lab = _stroke(d, hw, hit.foot_l_m)
        span = in_view
        if np.isfinite(line.start_s_m) or np.isfinite(line.end_s_m):
            span = span & (s >= line.start_s_m) & (s < line.end_s_m)
        if crosswalk is not None:
            span = span & ~crosswalk
        if line.style is LineStyle.DASHED:
            period = line.dash_m + line.gap_m
            m = fmod_pos(s - np.float32(line.phase_m), period)
            along = np.minimum(m, np.float32(line.dash_m) - m)
            cov = cov * np.clip(along / hit.foot_s_m + np.float32(0.5), 0.0, 1.0)
            lab &= m < line.dash_m
        lab &= span
        cov = cov * span
        if line.wear > 0:
            keep = np.clip(
                np.float32(1.0 - 1.2 * line.wear) + np.float32(0.45 * line.wear) * (grain + blotch),
                0.0,
                1.0,
            )
            cov = cov * keep
        _blend(color, cov * np.float32(0.92), paint_col)
        if line.wear < 0.999:
            labels[lab] = line_label(line)

    # --- stop lines and zebra crosswalks --------------------------------------------------
    if road.stop_lines_s_m:
        lo, hi = _stop_line_span(road)
        across = on_road & (l_m >= lo) & (l_m <= hi)
        for s_stop in road.stop_lines_s_m:
            d = np.abs(s - np.float32(s_stop + 0.5 * _STOP_LINE_WIDTH_M))
            cov, lab = _stroke(d, 0.5 * _STOP_LINE_WIDTH_M, hit.foot_s_m)
            _blend(color, cov * across, palette.white_paint)
            labels[lab & across] = STOP_LINE
    if crosswalk is not None:
        zm = fmod_pos(l_m, 2 * _ZEBRA_STRIPE_M)
        dz = np.abs(zm - np.float32(0.5 * _ZEBRA_STRIPE_M))
        cov, lab = _stroke(dz, 0.5 * _ZEBRA_STRIPE_M, hit.foot_l_m)
        zone = crosswalk & on_road
        _blend(color, cov * zone * np.float32(0.9), palette.white_paint)
        labels[lab & zone] = CROSSWALK

    if wet > 0:
        color *= np.float32(1.0 - 0.35 * wet)
        gloss = np.maximum(gloss, np.float32(wet) * on_road)
    return Ground(color, labels, gloss)


def _stop_line_span(road: RoadProfile) -> tuple[float, float]:
    """Return the lateral span (m) of stop lines: the lanes right of the first yellow line."""
    offs = sorted(road.lines, key=lambda ln: ln.offset_m)
    if not offs:
        return road.right_edge_m, road.left_edge_m
    lo = offs[0].offset_m
    hi = offs[-1].offset_m
    for ln in offs:
        if ln.color is LineColor.YELLOW and ln.offset_m > lo:
            hi = ln.offset_m
            break
    return lo, hi


def _blend(color: F32, alpha: F32, rgb: tuple[float, float, float]) -> None:
    """Blend ``rgb`` over ``color`` in place with per-pixel ``alpha`` (0..1)."""
    for ch in range(3):
        c = color[..., ch]
        c += alpha * (np.float32(rgb[ch]) - c)
