"""Ground pixels: hierarchical labels and colours of road, markings, shoulders and terrain.

Everything is evaluated in road coordinates ``(s, l)`` from :mod:`.raycast`, so markings land
exactly where the lines are and textures stay fixed on the road while the car moves. Paint is
anti-aliased with the pixel footprint in metres; labels use the pixel centre (widened to one
pixel where a line is thinner than a pixel, so far lines stay connected in the masks).
The unpainted surface is in :mod:`._surface`; this module paints the markings on it.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from superlane_tools.hierarchy import LEAF_IDS
from superlane_tools.simulation.render._surface import (
    DEFAULT_PALETTE,
    GroundLight,
    HalfGrid,
    Palette,
    fmod_pos,
    surface_color,
)
from superlane_tools.simulation.render.raycast import (
    MAX_FOOTPRINT_M,
    RoadHit,
    footprint,
    footprint_at,
)
from superlane_tools.simulation.render.textures import (
    COARSE_TEXEL_M,
    FINE_TEXEL_M,
    RoadTextures,
)
from superlane_tools.simulation.scene import LaneLine, LineColor, LineStyle, RoadProfile

__all__ = [
    "CROSSWALK",
    "DEFAULT_PALETTE",
    "DRIVABLE_IDS",
    "ROAD",
    "SIDEWALK",
    "STOP_LINE",
    "TERRAIN",
    "Ground",
    "GroundLight",
    "Palette",
    "fmod_pos",
    "ground_labels",
    "line_label",
    "line_offset",
    "shade_ground",
]

F32 = NDArray[np.float32]
F = np.float32
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
_DOT_M = 0.12  # raised pavement marker size
_DOT_BGR = (215.0, 222.0, 228.0)


class Ground(NamedTuple):
    """Shaded ground of rows ``hit.row0:``.

    Attributes:
        color: ``(R, W, 3)`` float32 BGR, lit and hazed (meaningless where labels are 0).
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


def _in_ranges(s: F32, ranges: tuple[tuple[float, float], ...]) -> NDArray[np.bool_]:
    out = np.zeros(s.shape, bool)
    for a, b in ranges:
        out |= (s >= a) & (s < b)
    return out


def ground_labels(
    hit: RoadHit, road: RoadProfile
) -> tuple[U8, NDArray[np.bool_], NDArray[np.bool_]]:
    """Return bare-ground leaf ids (road, sidewalk, terrain) and the on-road and sidewalk masks."""
    l_m, valid = hit.l_m, hit.hit
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
        side = np.zeros(l_m.shape, bool)
    return labels, on_road, side


def shade_ground(
    hit: RoadHit,
    road: RoadProfile,
    tex: RoadTextures,
    palette: Palette,
    cracks: float,
    tar_seams: float,
    wet: float,
    light: GroundLight,
    out: F32 | None = None,
    road_dots: bool = False,
) -> Ground:
    """Label, colour, light and haze the ground pixels of ``hit`` (see the module docstring).

    The surface colour (textures, tyre tracks, cracks, seams, terrain) is smooth at the pixel
    scale, so it is evaluated on every second row and column and resized up; painted lines are
    evaluated at full resolution, but only on the pixels near a line (found on that half grid).

    Args:
        hit: Ray-cast road coordinates of the rows below the horizon.
        road: The road profile (lines, edges, crosswalks, stop lines).
        tex: Textures of this world.
        palette: Base colours.
        cracks: Crack and patch density 0..1.
        tar_seams: Tar-seam (sealant line) density 0..1.
        wet: Wetness 0..1 (darkens the surface, raises gloss).
        light: Illumination and haze on the half grid.
        out: ``(R, W, 3)`` float32 array to write the colour into (a new one if None).
        road_dots: Raised pavement markers in the gaps of dashed lines (appearance only).
    """
    import cv2

    s, l_m, valid = hit.s_m, hit.l_m, hit.hit
    rows, cols = s.shape
    labels, on_road, side = ground_labels(hit, road)
    hs, hl, hv = s[::2, ::2], l_m[::2, ::2], valid[::2, ::2]
    # Footprints of the half grid: differences over two pixels.
    half = HalfGrid(
        hs, hl, footprint(hl, hv), footprint(hs, hv), hv, on_road[::2, ::2], side[::2, ::2]
    )
    color_h, gloss_h = surface_color(half, road, tex, palette, cracks, tar_seams, wet, light)
    color = np.empty((rows, cols, 3), np.float32) if out is None else out
    cv2.resize(color_h, (cols, rows), dst=color, interpolation=cv2.INTER_LINEAR)
    if tar_seams > 0 or wet > 0:
        gloss = np.asarray(
            cv2.resize(gloss_h, (cols, rows), interpolation=cv2.INTER_LINEAR), dtype=np.float32
        )
    else:
        gloss = np.zeros((rows, cols), np.float32)
    _paint_lines(hit, road, tex, palette, half, light, color, labels, road_dots)

    if road.stop_lines_s_m or road.crosswalks_s_m:
        _paint_transverse(hit, road, palette, half, light, on_road, color, labels)
    return Ground(color, labels, gloss)


def _paint_lines(
    hit: RoadHit,
    road: RoadProfile,
    tex: RoadTextures,
    palette: Palette,
    half: HalfGrid,
    light: GroundLight,
    color: F32,
    labels: U8,
    road_dots: bool = False,
) -> None:
    """Paint the longitudinal lines (colour and labels) at full resolution, in place.

    With ``road_dots``, dashed lines get a raised pavement marker in each gap (appearance only:
    the pixels stay labelled road).
    """
    idx = _line_candidates(road, half, color.shape[:2])
    if idx.size == 0:
        return
    px = _line_pixels(hit, road, half, light, color, labels, idx)
    for line in road.lines:
        _paint_line(line, px, tex, palette, light.haze_bgr, road_dots)
    color.reshape(-1, 3)[idx] = px.col
    labels.reshape(-1)[idx] = px.lab


def _line_candidates(road: RoadProfile, half: HalfGrid, shape: tuple[int, ...]) -> NDArray[np.intp]:
    """Return the flat indices of the full-resolution pixels that may be near a line.

    Only pixels within a few footprints of a line on the half grid are evaluated: a full
    resolution pixel lies at most one half-grid footprint from its half-grid sample, so the
    candidate set (widened by one half-grid pixel) contains every painted or labelled pixel.
    """
    import cv2

    rows, cols = shape
    cand = np.zeros(half.s.shape, bool)
    for line in road.lines:
        d = np.abs(half.l_m - line_offset(line, half.s))
        hw = 0.5 * line.width_m
        if line.style is LineStyle.DOUBLE:
            d = np.abs(d - np.float32(hw + 0.5 * _DOUBLE_GAP_M))
        cand |= d < np.float32(hw) + np.float32(2.0) * half.foot_l
    # Where the footprint is clipped (horizon, crests) it says nothing about the true variation
    # between samples: evaluate everything there.
    cand |= half.foot_l >= np.float32(MAX_FOOTPRINT_M)
    cand &= half.valid
    grown = cv2.dilate(cand.view(np.uint8), np.ones((3, 3), np.uint8))
    full = cv2.resize(grown, (cols, rows), interpolation=cv2.INTER_NEAREST)
    return np.flatnonzero(full)


class _LinePixels(NamedTuple):
    """What the lines are painted from and into, at the candidate pixels (1-D arrays).

    ``col`` and ``lab`` are copies of the frame's colour and labels there, painted in place and
    written back once; ``cross`` is None without crosswalks.
    """

    s: F32
    l_m: F32
    foot_l: F32
    foot_s: F32
    gain: F32
    airlight: F32
    in_view: NDArray[np.bool_]
    cross: NDArray[np.bool_] | None
    col: F32
    lab: U8


def _line_pixels(
    hit: RoadHit,
    road: RoadProfile,
    half: HalfGrid,
    light: GroundLight,
    color: F32,
    labels: U8,
    idx: NDArray[np.intp],
) -> _LinePixels:
    """Gather road coordinates, footprints, light and the current colour at pixels ``idx``."""
    cols = color.shape[1]
    s = hit.s_m.reshape(-1)[idx]
    l_m = hit.l_m.reshape(-1)[idx]
    foot_l = footprint_at(hit.l_m, hit.hit, idx)
    foot_s = footprint_at(hit.s_m, hit.hit, idx)
    valid = hit.hit.reshape(-1)[idx]
    col = color.reshape(-1, 3)[idx]
    lab = labels.reshape(-1)[idx]
    r, c = np.divmod(idx, cols)
    hidx = (r // 2) * half.s.shape[1] + c // 2
    gain = light.gain.reshape(-1)[hidx]
    airlight = light.haze.reshape(-1)[hidx]
    in_view_all = valid & (s >= road.s_m[0]) & (s <= road.s_m[-1])
    cross_all = _in_ranges(s, road.crosswalks_s_m) if road.crosswalks_s_m else None
    return _LinePixels(s, l_m, foot_l, foot_s, gain, airlight, in_view_all, cross_all, col, lab)


def _paint_line(
    line: LaneLine,
    px: _LinePixels,
    tex: RoadTextures,
    palette: Palette,
    haze_bgr: tuple[float, float, float],
    road_dots: bool,
) -> None:
    """Paint one line into ``px.col`` and label it in ``px.lab`` (dashes, wear, markers)."""
    paint_col = palette.yellow_paint if line.color is LineColor.YELLOW else palette.white_paint
    hw = 0.5 * line.width_m
    d_all = np.abs(px.l_m - line_offset(line, px.s))
    if line.style is LineStyle.DOUBLE:
        d_all = np.abs(d_all - np.float32(hw + 0.5 * _DOUBLE_GAP_M))
    # This line's own pixels: paint coverage or label needs d < hw + foot / 2.
    sub = np.flatnonzero(d_all < np.float32(hw) + np.float32(0.5) * px.foot_l)
    if sub.size == 0:
        return
    d, fl, ss, foot_s = d_all[sub], px.foot_l[sub], px.s[sub], px.foot_s[sub]
    cov, mark = _stroke(d, hw, fl)
    span = px.in_view[sub]
    if np.isfinite(line.start_s_m) or np.isfinite(line.end_s_m):
        span = span & (ss >= line.start_s_m) & (ss < line.end_s_m)
    if px.cross is not None:
        span = span & ~px.cross[sub]
    if line.style is LineStyle.DASHED:
        period = line.dash_m + line.gap_m
        m = fmod_pos(ss - np.float32(line.phase_m), period)
        along = np.minimum(m, np.float32(line.dash_m) - m)
        cov = cov * np.clip(along / foot_s + np.float32(0.5), 0.0, 1.0)
        mark &= m < line.dash_m
    mark &= span
    cov = cov * span
    if line.wear > 0:
        wear_tex = _wear_texture(tex, ss, px.l_m[sub], fl)
        keep = np.clip(
            np.float32(1.0 - 1.2 * line.wear) + np.float32(0.45 * line.wear) * wear_tex,
            0.0,
            1.0,
        )
        cov = cov * keep
    gain, airlight = px.gain[sub, None], px.airlight[sub, None]
    lit = np.array(paint_col, np.float32) * gain
    lit += airlight * np.array(haze_bgr, np.float32)
    cs = px.col[sub]
    cs += (cov * np.float32(0.92))[:, None] * (lit - cs)
    if road_dots and line.style is LineStyle.DASHED:
        # A raised pavement marker (~10 cm reflector) in the middle of each gap.
        gap_d = np.abs(m - np.float32(line.dash_m + 0.5 * line.gap_m))
        dot = np.clip((np.float32(_DOT_M / 2) - d) / fl + np.float32(0.5), 0.0, 1.0)
        dot *= np.clip((np.float32(_DOT_M / 2) - gap_d) / foot_s + np.float32(0.5), 0, 1)
        dot *= span
        shine = np.array(_DOT_BGR, np.float32) * gain
        shine += airlight * np.array(haze_bgr, np.float32)
        cs += (dot * np.float32(0.9))[:, None] * (shine - cs)
    px.col[sub] = cs
    if line.wear < 0.999:
        ls = px.lab[sub]
        ls[mark] = line_label(line)
        px.lab[sub] = ls


def _paint_transverse(
    hit: RoadHit,
    road: RoadProfile,
    palette: Palette,
    half: HalfGrid,
    light: GroundLight,
    on_road: NDArray[np.bool_],
    color: F32,
    labels: U8,
) -> None:
    """Paint stop lines and zebra crosswalks (colour and labels), on their own pixels only."""
    s, l_m = hit.s_m, hit.l_m
    cols = s.shape[1]
    # A stop line's label may widen by half a (clipped) footprint: look that far around it.
    reach = 0.5 * MAX_FOOTPRINT_M + _STOP_LINE_WIDTH_M
    sel = np.zeros(s.shape, bool)
    for s_stop in road.stop_lines_s_m:
        sel |= (s > np.float32(s_stop - reach)) & (s < np.float32(s_stop + reach))
    for a, b in road.crosswalks_s_m:
        sel |= (s >= a) & (s < b)
    sel &= on_road
    idx = np.flatnonzero(sel)
    if idx.size == 0:
        return
    ss, ll = s.reshape(-1)[idx], l_m.reshape(-1)[idx]
    r, c = np.divmod(idx, cols)
    hidx = (r // 2) * half.s.shape[1] + c // 2
    gain, air = light.gain.reshape(-1)[hidx], light.haze.reshape(-1)[hidx]
    col = color.reshape(-1, 3)[idx]
    lab = labels.reshape(-1)[idx]
    white = np.array(palette.white_paint, np.float32) * gain[:, None]
    white += air[:, None] * np.array(light.haze_bgr, np.float32)
    if road.stop_lines_s_m:
        foot_s = footprint_at(s, hit.hit, idx)
        lo, hi = _stop_line_span(road)
        across = (ll >= lo) & (ll <= hi)
        for s_stop in road.stop_lines_s_m:
            d = np.abs(ss - np.float32(s_stop + 0.5 * _STOP_LINE_WIDTH_M))
            cov, mark = _stroke(d, 0.5 * _STOP_LINE_WIDTH_M, foot_s)
            col += (cov * across)[:, None] * (white - col)
            lab[mark & across] = STOP_LINE
    if road.crosswalks_s_m:
        zone = _in_ranges(ss, road.crosswalks_s_m)
        zm = fmod_pos(ll, 2 * _ZEBRA_STRIPE_M)
        dz = np.abs(zm - np.float32(0.5 * _ZEBRA_STRIPE_M))
        cov, mark = _stroke(dz, 0.5 * _ZEBRA_STRIPE_M, footprint_at(l_m, hit.hit, idx))
        col += (cov * zone * np.float32(0.9))[:, None] * (white - col)
        lab[mark & zone] = CROSSWALK
    color.reshape(-1, 3)[idx] = col
    labels.reshape(-1)[idx] = lab


def _wear_texture(tex: RoadTextures, s: F32, l_m: F32, foot_l: F32) -> F32:
    """Return grain + blotch noise at scattered road points (patchy paint wear)."""
    n_lev = tex.fine.shape[0]
    ratio = foot_l / np.float32(2.0 * FINE_TEXEL_M)
    lev = np.clip(np.floor(np.log2(np.maximum(ratio, 1.0))), 0, n_lev - 1).astype(np.int32)
    n, h, w = tex.fine.shape
    ia = (s * np.float32(1.0 / FINE_TEXEL_M)).astype(np.int32) & (w - 1)
    ib = (l_m * np.float32(1.0 / FINE_TEXEL_M)).astype(np.int32) & (h - 1)
    grain = tex.fine.reshape(n * h, w)[lev * h + ib, ia]
    ic = (s * np.float32(1.0 / COARSE_TEXEL_M)).astype(np.int32) & 255
    jc = (l_m * np.float32(1.0 / COARSE_TEXEL_M)).astype(np.int32) & 255
    out: F32 = grain + tex.coarse[jc, ic]
    return out


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
