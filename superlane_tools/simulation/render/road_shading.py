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
        color: ``(R, W, 3)`` float32 BGR, lit and hazed (meaningless where labels are 0).
        labels: ``(R, W)`` leaf ids (0 where the ray misses the ground).
        gloss: ``(R, W)`` specular weight 0..1 (wet asphalt, tar seams) for reflections.
    """

    color: F32
    labels: U8
    gloss: F32


class GroundLight(NamedTuple):
    """Light and haze on the half grid (every second row and column of the ground rows).

    The shaded colour ``c`` becomes ``c * gain + haze * haze_bgr`` (illumination times the
    transmitted fraction, plus the airlight), both smooth at the pixel scale.

    Attributes:
        gain: ``(ceil(R / 2), ceil(W / 2))`` illumination times transmission.
        haze: Same shape, airlight fraction ``1 - transmission``.
        haze_bgr: Airlight colour, BGR grey levels.
    """

    gain: F32
    haze: F32
    haze_bgr: tuple[float, float, float]


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
    """Sample a mip chain at road coordinates ``a`` (along) and ``b`` (across).

    ``levels`` is the mip level per row of 2-D ``a`` (or per element of 1-D ``a``).
    """
    n, h, w = mips.shape
    ia = (a * np.float32(1.0 / texel_m)).astype(np.intp) & (w - 1)
    ib = (b * np.float32(1.0 / texel_m)).astype(np.intp) & (h - 1)
    lev = levels[:, None] if a.ndim == 2 else levels
    out: F32 = mips.reshape(n * h, w)[lev * h + ib, ia]
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
    half = _Half(
        hs, hl, footprint(hl, hv), footprint(hs, hv), hv, on_road[::2, ::2], side[::2, ::2]
    )
    color_h, gloss_h = _surface(half, road, tex, palette, cracks, tar_seams, wet, light)
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


class _Half(NamedTuple):
    """Road coordinates on every second row and column (footprints of that coarser grid)."""

    s: F32
    l_m: F32
    foot_l: F32
    foot_s: F32
    valid: NDArray[np.bool_]
    on_road: NDArray[np.bool_]
    side: NDArray[np.bool_]


def _tyre_profile(road: RoadProfile) -> F32:
    """Return the lateral shading profile (tyre tracks, slab joints) on a 2 cm grid from -40 m."""
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
    return prof


def _surface(
    g: _Half,
    road: RoadProfile,
    tex: RoadTextures,
    palette: Palette,
    cracks: float,
    tar_seams: float,
    wet: float,
    light: GroundLight,
) -> tuple[F32, F32]:
    """Return the unpainted, lit and hazed ground colour and the gloss of the half grid.

    The colour is one linear map of per-pixel weights (surface shade, seam coverage, airlight)
    applied with ``cv2.transform``, which is much faster than channel-wise numpy blends.
    """
    import cv2

    s, l_m = g.s, g.l_m
    lev = _tex_levels(g.foot_l, FINE_TEXEL_M, tex.fine.shape[0])
    grain = _sample_mip(tex.fine, FINE_TEXEL_M, s, l_m, lev)
    ic = (s * np.float32(1.0 / COARSE_TEXEL_M)).astype(np.int32) & 255
    jc = (l_m * np.float32(1.0 / COARSE_TEXEL_M)).astype(np.int32) & 255
    blotch = tex.coarse[jc, ic]
    surf = palette.concrete if road.surface == "concrete" else palette.asphalt
    shade = np.float32(1.0) + np.float32(0.07) * grain + np.float32(0.06) * blotch
    prof = _tyre_profile(road)
    li = np.clip(((l_m + 40.0) * 50.0).astype(np.int32), 0, prof.size - 1)
    shade *= prof[li]
    if road.surface == "concrete":  # transverse slab joints every 4.6 m
        jm = fmod_pos(s, 4.6)
        joint = np.clip(np.float32(0.03) / g.foot_s, 0.0, 1.0) * (jm < 0.03 + g.foot_s)
        shade *= np.float32(1.0) - np.float32(0.25) * joint
    gloss = np.zeros(s.shape, np.float32)
    if cracks > 0:
        crack = _sample_bilinear(tex.cracks, s, l_m, 4.0 / COARSE_TEXEL_M)
        crack *= np.float32(min(1.0, cracks * 1.5))
        crack *= np.clip(np.float32(0.1) / g.foot_l, 0.0, 1.0)
        patch = (blotch > np.float32(2.2 - 1.2 * cracks)).astype(np.float32)
        shade *= (np.float32(1.0) - np.float32(0.45) * crack) * (
            np.float32(1.0) - np.float32(0.12) * patch
        )
    gain = light.gain * np.float32(1.0 - 0.35 * wet) if wet > 0 else light.gain
    shade *= gain
    hz = light.haze_bgr
    if tar_seams > 0:
        seam = _sample_bilinear(tex.seams, s, l_m, 1.5 / COARSE_TEXEL_M)
        seam *= np.float32(min(1.0, 1.3 * tar_seams))
        seam *= np.clip(np.float32(0.08) / g.foot_l, 0.0, 1.0) * g.on_road
        np.minimum(seam, np.float32(1.0), out=seam)
        gloss = np.maximum(gloss, seam)
        weights = cv2.merge([shade * (np.float32(1.0) - seam), seam * gain, light.haze])
        mat = np.array([[surf[c], palette.seam[c], hz[c]] for c in range(3)], np.float32)
    else:
        weights = cv2.merge([shade, light.haze])
        mat = np.array([[surf[c], hz[c]] for c in range(3)], np.float32)
    color = np.asarray(cv2.transform(weights, mat), dtype=np.float32)
    if wet > 0:
        gloss = np.maximum(gloss, np.float32(wet) * g.on_road)

    off = np.flatnonzero(g.valid & ~g.on_road)
    if off.size:  # terrain and sidewalks, evaluated on their own pixels only
        so, lo = s.reshape(-1)[off], l_m.reshape(-1)[off]
        glev = _tex_levels(g.foot_l, 4 * FINE_TEXEL_M, tex.grass.shape[0])
        gr = _sample_mip(tex.grass, 4 * FINE_TEXEL_M, so, lo, glev[off // s.shape[1]])
        edge_d = np.maximum(lo - np.float32(road.left_edge_m), np.float32(road.right_edge_m) - lo)
        dirt_w = np.clip(np.float32(1.6) - edge_d, 0.0, 1.0)  # gravel strip next to the asphalt
        mix = np.clip(np.float32(0.5) + np.float32(0.35) * blotch.reshape(-1)[off] + dirt_w, 0, 1)
        tshade = np.float32(1.0) + np.float32(0.18) * gr
        grass = np.array(palette.grass, np.float32)
        dirt = np.array(palette.dirt, np.float32)
        terr = (grass + mix[:, None] * (dirt - grass)) * tshade[:, None]
        side = g.side.reshape(-1)[off]
        if np.any(side):
            side_c = (np.float32(1.0) + np.float32(0.05) * grain.reshape(-1)[off])[:, None] * (
                np.array(palette.sidewalk, np.float32)
            )
            terr = np.where(side[:, None], side_c, terr)
        terr *= gain.reshape(-1)[off, None]
        terr += light.haze.reshape(-1)[off, None] * np.array(hz, np.float32)
        color.reshape(-1, 3)[off] = terr
    return color, gloss


def _sample_bilinear(tex: F32, s: F32, l_m: F32, texels_per_m: float) -> F32:
    """Sample a wrapping ``(256, 256)`` texture bilinearly at ``(s, l)`` (smooth up close)."""
    import cv2

    n = tex.shape[0]
    k = np.float32(texels_per_m)
    u = fmod_pos(s * k, n)
    v = fmod_pos(l_m * k, n)
    out = cv2.remap(tex, u, v, cv2.INTER_LINEAR, borderMode=cv2.BORDER_WRAP)
    return np.asarray(out, dtype=np.float32)


def _paint_lines(
    hit: RoadHit,
    road: RoadProfile,
    tex: RoadTextures,
    palette: Palette,
    half: _Half,
    light: GroundLight,
    color: F32,
    labels: U8,
    road_dots: bool = False,
) -> None:
    """Paint the longitudinal lines (colour and labels) at full resolution, in place.

    With ``road_dots``, dashed lines get a raised pavement marker in each gap (appearance only:
    the pixels stay labelled road).

    Only pixels within a few footprints of a line on the half grid are evaluated: a full
    resolution pixel lies at most one half-grid footprint from its half-grid sample, so the
    candidate set (widened by one half-grid pixel) contains every painted or labelled pixel.
    """
    import cv2

    rows, cols = color.shape[:2]
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
    idx = np.flatnonzero(full)
    if idx.size == 0:
        return
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
    for line in road.lines:
        paint_col = palette.yellow_paint if line.color is LineColor.YELLOW else palette.white_paint
        hw = 0.5 * line.width_m
        d_all = np.abs(l_m - line_offset(line, s))
        if line.style is LineStyle.DOUBLE:
            d_all = np.abs(d_all - np.float32(hw + 0.5 * _DOUBLE_GAP_M))
        # This line's own pixels: paint coverage or label needs d < hw + foot / 2.
        sub = np.flatnonzero(d_all < np.float32(hw) + np.float32(0.5) * foot_l)
        if sub.size == 0:
            continue
        d, fl, ss = d_all[sub], foot_l[sub], s[sub]
        cov, mark = _stroke(d, hw, fl)
        span = in_view_all[sub]
        if np.isfinite(line.start_s_m) or np.isfinite(line.end_s_m):
            span = span & (ss >= line.start_s_m) & (ss < line.end_s_m)
        if cross_all is not None:
            span = span & ~cross_all[sub]
        if line.style is LineStyle.DASHED:
            period = line.dash_m + line.gap_m
            m = fmod_pos(ss - np.float32(line.phase_m), period)
            along = np.minimum(m, np.float32(line.dash_m) - m)
            cov = cov * np.clip(along / foot_s[sub] + np.float32(0.5), 0.0, 1.0)
            mark &= m < line.dash_m
        mark &= span
        cov = cov * span
        if line.wear > 0:
            wear_tex = _wear_texture(tex, ss, l_m[sub], fl)
            keep = np.clip(
                np.float32(1.0 - 1.2 * line.wear) + np.float32(0.45 * line.wear) * wear_tex,
                0.0,
                1.0,
            )
            cov = cov * keep
        lit = np.array(paint_col, np.float32) * gain[sub, None]
        lit += airlight[sub, None] * np.array(light.haze_bgr, np.float32)
        cs = col[sub]
        cs += (cov * np.float32(0.92))[:, None] * (lit - cs)
        if road_dots and line.style is LineStyle.DASHED:
            # A raised pavement marker (~10 cm reflector) in the middle of each gap.
            gap_d = np.abs(m - np.float32(line.dash_m + 0.5 * line.gap_m))
            dot = np.clip((np.float32(_DOT_M / 2) - d) / fl + np.float32(0.5), 0.0, 1.0)
            dot *= np.clip((np.float32(_DOT_M / 2) - gap_d) / foot_s[sub] + np.float32(0.5), 0, 1)
            dot *= span
            shine = np.array(_DOT_BGR, np.float32) * gain[sub, None]
            shine += airlight[sub, None] * np.array(light.haze_bgr, np.float32)
            cs += (dot * np.float32(0.9))[:, None] * (shine - cs)
        col[sub] = cs
        if line.wear < 0.999:
            ls = lab[sub]
            ls[mark] = line_label(line)
            lab[sub] = ls
    color.reshape(-1, 3)[idx] = col
    labels.reshape(-1)[idx] = lab


def _paint_transverse(
    hit: RoadHit,
    road: RoadProfile,
    palette: Palette,
    half: _Half,
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
