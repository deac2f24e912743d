"""Tileable procedural textures, generated once per world seed and sampled in road coordinates."""

from __future__ import annotations

from functools import lru_cache
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

F32 = NDArray[np.float32]

#: Texel size of the fine road texture, metres (a 512 texel tile covers 6.4 m).
FINE_TEXEL_M = 0.0125
#: Texel size of the coarse road texture, metres (a 256 texel tile covers 51.2 m).
COARSE_TEXEL_M = 0.2


class RoadTextures(NamedTuple):
    """Road-surface textures of one world (values roughly zero-mean, unit-ish amplitude).

    Attributes:
        fine: ``(levels, 512, 512)`` grain noise, level ``k`` blurred for footprints ~``2**k``
            texels (a hand-made mip chain at full size, so one gather serves every level).
        coarse: ``(256, 256)`` large blotches: wear, repairs, stains.
        cracks: ``(256, 256)`` crack darkness 0..1 at ``COARSE_TEXEL_M / 4`` metres per texel.
        seams: ``(256, 256)`` tar-seam (sealant) coverage 0..1, same texel size as ``cracks``.
        grass: ``(levels, 256, 256)`` terrain noise at ``4 * FINE_TEXEL_M`` per texel, mip chain.
        clouds: ``(256, 1024)`` cloud density 0..1 over (elevation, azimuth).
        skyline: ``(2048,)`` elevation (radians) of distant hills per azimuth bin.
        treeline: ``(2048,)`` elevation (radians) of the distant tree line per azimuth bin.
    """

    fine: F32
    coarse: F32
    cracks: F32
    seams: F32
    grass: F32
    clouds: F32
    skyline: F32
    treeline: F32


def spectral_noise(rng: np.random.Generator, shape: tuple[int, int], beta: float) -> F32:
    """Return tileable ``1/f**beta`` noise of ``shape``, zero mean, unit standard deviation."""
    white = rng.standard_normal(shape)
    spec = np.fft.rfft2(white)
    fy = np.fft.fftfreq(shape[0])[:, None]
    fx = np.fft.rfftfreq(shape[1])[None, :]
    f = np.sqrt(fx * fx + fy * fy)
    f[0, 0] = 1.0
    spec *= f**-beta
    spec[0, 0] = 0.0
    out = np.fft.irfft2(spec, s=shape)
    out /= out.std() + 1e-12
    return out.astype(np.float32)


def _mip_chain(base: F32, levels: int) -> F32:
    """Return ``base`` and progressively blurred (wrap-around) copies stacked on axis 0."""
    import cv2

    out = [base]
    cur = base
    for _ in range(1, levels):
        pad = cv2.copyMakeBorder(cur, 8, 8, 8, 8, cv2.BORDER_WRAP)
        cur = np.asarray(cv2.GaussianBlur(pad, (0, 0), 1.5)[8:-8, 8:-8], dtype=np.float32)
        out.append(cur)
    return np.stack(out).astype(np.float32)


def _crack_field(rng: np.random.Generator, size: int, count: int, width: int) -> F32:
    """Return a tileable field of meandering random-walk polylines (0..1)."""
    import cv2

    big = np.zeros((size * 3, size * 3), np.float32)
    for _ in range(count):
        p = rng.uniform(size, 2 * size, 2)
        ang = rng.uniform(0, 2 * np.pi)
        pts = [p.copy()]
        for _ in range(int(rng.integers(8, 30))):
            ang += rng.normal(0, 0.5)
            p = p + 6.0 * np.array([np.cos(ang), np.sin(ang)])
            pts.append(p.copy())
        poly = np.round(np.array(pts)).astype(np.int32).reshape(-1, 1, 2)
        cv2.polylines(big, [poly], False, float(rng.uniform(0.5, 1.0)), width, cv2.LINE_AA)
    # Fold the 3x3 canvas onto one tile so the field wraps around seamlessly.
    tile = np.zeros((size, size), np.float32)
    for i in range(3):
        for j in range(3):
            tile = np.maximum(tile, big[i * size : (i + 1) * size, j * size : (j + 1) * size])
    return tile


@lru_cache(maxsize=4)
def road_textures(world_seed: int) -> RoadTextures:
    """Return the (cached) textures of world ``world_seed``."""
    rng = np.random.default_rng([world_seed, 0x7E47])
    fine = _mip_chain(spectral_noise(rng, (512, 512), 0.6), 5)
    coarse = spectral_noise(rng, (256, 256), 1.3)
    cracks = _crack_field(rng, 256, 14, 1)
    seams = _crack_field(rng, 256, 10, 2)
    grass = _mip_chain(spectral_noise(rng, (256, 256), 0.9), 5)
    c = spectral_noise(rng, (256, 1024), 1.6)
    clouds = np.clip((c - 0.2) * 0.8, 0.0, 1.0).astype(np.float32)
    hills = spectral_noise(rng, (1, 2048), 1.8)[0]
    skyline = (0.012 + 0.012 * hills).clip(0.0, None).astype(np.float32)
    trees = spectral_noise(rng, (1, 2048), 0.9)[0]
    treeline = (0.006 + 0.004 * trees).clip(0.0, None).astype(np.float32)
    return RoadTextures(fine, coarse, cracks, seams, grass, clouds, skyline, treeline)


def sample_wrapped(tex: F32, u_idx: NDArray[np.int32], v_idx: NDArray[np.int32]) -> F32:
    """Gather ``tex[v, u]`` with wrap-around (power-of-two sizes)."""
    h, w = tex.shape[-2:]
    out: F32 = tex[v_idx & (h - 1), u_idx & (w - 1)]
    return out
