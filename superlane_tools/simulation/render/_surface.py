"""The unpainted ground on the half grid: road texture, tracks, joints, cracks, seams, terrain.

Also what the painted markings share with it: the palette, the light and road coordinates of
the half grid, a float modulo (the API: :mod:`.road_shading`).
"""

from __future__ import annotations

import itertools
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from superlane_tools.simulation.render.textures import (
    COARSE_TEXEL_M,
    FINE_TEXEL_M,
    RoadTextures,
)
from superlane_tools.simulation.scene import RoadProfile

F32 = NDArray[np.float32]


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


class HalfGrid(NamedTuple):
    """Road coordinates on every second row and column (footprints of that coarser grid)."""

    s: F32
    l_m: F32
    foot_l: F32
    foot_s: F32
    valid: NDArray[np.bool_]
    on_road: NDArray[np.bool_]
    side: NDArray[np.bool_]


def fmod_pos(a: F32, period: float) -> F32:
    """Return ``a`` modulo ``period`` in ``[0, period)`` (faster than ``np.mod`` for float32)."""
    p = np.float32(period)
    out: F32 = a - np.floor(a * np.float32(1.0 / period)) * p
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


def _sample_bilinear(tex: F32, s: F32, l_m: F32, texels_per_m: float) -> F32:
    """Sample a wrapping ``(256, 256)`` texture bilinearly at ``(s, l)`` (smooth up close)."""
    import cv2

    n = tex.shape[0]
    k = np.float32(texels_per_m)
    u = fmod_pos(s * k, n)
    v = fmod_pos(l_m * k, n)
    out = cv2.remap(tex, u, v, cv2.INTER_LINEAR, borderMode=cv2.BORDER_WRAP)
    return np.asarray(out, dtype=np.float32)


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


def surface_color(
    g: HalfGrid,
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
    shade, grain, blotch = _road_shade(g, road, tex, cracks)
    surf = palette.concrete if road.surface == "concrete" else palette.asphalt
    gloss = np.zeros(s.shape, np.float32)
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
    _paint_terrain(color, g, road, tex, palette, grain, blotch, gain, light)
    return color, gloss


def _road_shade(
    g: HalfGrid, road: RoadProfile, tex: RoadTextures, cracks: float
) -> tuple[F32, F32, F32]:
    """Return the unlit shade of the road surface and the grain and blotch textures under it.

    The shade (about 1) carries the texture, the tyre tracks, concrete slab joints, cracks and
    patches.
    """
    s, l_m = g.s, g.l_m
    lev = _tex_levels(g.foot_l, FINE_TEXEL_M, tex.fine.shape[0])
    grain = _sample_mip(tex.fine, FINE_TEXEL_M, s, l_m, lev)
    ic = (s * np.float32(1.0 / COARSE_TEXEL_M)).astype(np.int32) & 255
    jc = (l_m * np.float32(1.0 / COARSE_TEXEL_M)).astype(np.int32) & 255
    blotch = tex.coarse[jc, ic]
    shade = np.float32(1.0) + np.float32(0.07) * grain + np.float32(0.06) * blotch
    prof = _tyre_profile(road)
    li = np.clip(((l_m + 40.0) * 50.0).astype(np.int32), 0, prof.size - 1)
    shade *= prof[li]
    if road.surface == "concrete":  # transverse slab joints every 4.6 m
        jm = fmod_pos(s, 4.6)
        joint = np.clip(np.float32(0.03) / g.foot_s, 0.0, 1.0) * (jm < 0.03 + g.foot_s)
        shade *= np.float32(1.0) - np.float32(0.25) * joint
    if cracks > 0:
        crack = _sample_bilinear(tex.cracks, s, l_m, 4.0 / COARSE_TEXEL_M)
        crack *= np.float32(min(1.0, cracks * 1.5))
        crack *= np.clip(np.float32(0.1) / g.foot_l, 0.0, 1.0)
        patch = (blotch > np.float32(2.2 - 1.2 * cracks)).astype(np.float32)
        shade *= (np.float32(1.0) - np.float32(0.45) * crack) * (
            np.float32(1.0) - np.float32(0.12) * patch
        )
    return shade, grain, blotch


def _paint_terrain(
    color: F32,
    g: HalfGrid,
    road: RoadProfile,
    tex: RoadTextures,
    palette: Palette,
    grain: F32,
    blotch: F32,
    gain: F32,
    light: GroundLight,
) -> None:
    """Colour the terrain and sidewalks of ``color`` in place, evaluated on their pixels only.

    Grass and dirt mix with a gravel strip next to the paved edge; sidewalks are plain with a
    little grain; both are lit with ``gain`` and hazed.
    """
    s, l_m = g.s, g.l_m
    off = np.flatnonzero(g.valid & ~g.on_road)
    if not off.size:
        return
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
    terr += light.haze.reshape(-1)[off, None] * np.array(light.haze_bgr, np.float32)
    color.reshape(-1, 3)[off] = terr
