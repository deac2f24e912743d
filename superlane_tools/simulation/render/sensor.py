"""Camera sensor effects and domain randomisation: exposure, vignetting, blur, noise, tone."""

from __future__ import annotations

from functools import lru_cache
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from superlane_tools.simulation.render.road_shading import DEFAULT_PALETTE, Palette
from superlane_tools.simulation.scene import Conditions

F32 = NDArray[np.float32]
U8 = NDArray[np.uint8]

_BANK = 1 << 22


class Look(NamedTuple):
    """Per-frame appearance parameters (randomised for training data).

    Attributes:
        palette: Ground colours.
        gain_bgr: Per-channel white-balance gain.
        contrast: Contrast multiplier around mid-grey.
        brightness: Additive brightness, grey levels.
        noise_sigma: Sensor noise, grey levels.
    """

    palette: Palette
    gain_bgr: tuple[float, float, float]
    contrast: float
    brightness: float
    noise_sigma: float


def look_for(cond: Conditions, rng: np.random.Generator) -> Look:
    """Return the appearance of a frame: realistic defaults jittered by ``cond.randomize``."""
    r = float(np.clip(cond.randomize, 0.0, 1.0))
    if r <= 0:
        return Look(DEFAULT_PALETTE, (1.0, 1.0, 1.0), 1.0, 0.0, cond.noise_sigma)

    def jit(c: tuple[float, float, float], amount: float) -> tuple[float, float, float]:
        scale = 1.0 + rng.normal(0.0, 0.25 * r)
        tint = rng.normal(0.0, amount * r, 3)
        out = np.clip(np.array(c) * scale + tint, 5.0, 250.0)
        return (float(out[0]), float(out[1]), float(out[2]))

    p = DEFAULT_PALETTE
    palette = Palette(
        asphalt=jit(p.asphalt, 12.0),
        concrete=jit(p.concrete, 12.0),
        white_paint=jit(p.white_paint, 10.0),
        yellow_paint=jit(p.yellow_paint, 20.0),
        grass=jit(p.grass, 25.0),
        dirt=jit(p.dirt, 20.0),
        sidewalk=jit(p.sidewalk, 15.0),
        seam=jit(p.seam, 5.0),
    )
    g = np.exp(rng.normal(0.0, 0.08 * r, 3))
    return Look(
        palette,
        (float(g[0]), float(g[1]), float(g[2])),
        float(np.exp(rng.normal(0.0, 0.15 * r))),
        float(rng.normal(0.0, 12.0 * r)),
        float(cond.noise_sigma * np.exp(rng.normal(0.0, 0.5 * r))),
    )


@lru_cache(maxsize=1)
def _noise_bank() -> F32:
    """Return a fixed bank of standard-normal noise; frames read it at random offsets."""
    return np.random.default_rng(0x5E75).standard_normal(_BANK + 4096).astype(np.float32)


def finish(img: F32, vignette: F32, cond: Conditions, look: Look, rng: np.random.Generator) -> U8:
    """Apply exposure, tone, vignetting, motion blur and sensor noise; return uint8 BGR.

    Args:
        img: ``(H, W, 3)`` float32 scene radiance in grey levels (modified in place).
        vignette: ``(H, W)`` relative illumination.
        cond: Frame conditions (exposure, motion blur, noise).
        look: Appearance parameters.
        rng: The frame's random generator.
    """
    import cv2

    h, w = img.shape[:2]
    if cond.motion_blur_px >= 1.0:
        k = round(cond.motion_blur_px)
        blurred = cv2.blur(img, (max(1, k // 2), k))
        # Motion blur grows towards the image bottom (closer, faster-moving road).
        wgt = np.linspace(0.0, 1.0, h, dtype=np.float32)[:, None, None]
        img += wgt * (blurred - img)
    gain = np.array(look.gain_bgr, np.float32) * np.float32(cond.exposure)
    img *= vignette[..., None] * gain
    if look.contrast != 1.0 or look.brightness != 0.0:
        img -= np.float32(128.0)
        img *= np.float32(look.contrast)
        img += np.float32(128.0 + look.brightness)
    if look.noise_sigma > 0:
        n = h * w
        bank = _noise_bank()
        off = int(rng.integers(0, _BANK - n)) if n < _BANK else 0
        if n <= _BANK:
            noise = bank[off : off + n].reshape(h, w)
            # Shot noise: brighter pixels noisier; one luminance field plus small chroma noise.
            img += (noise * np.float32(look.noise_sigma))[..., None]
            off2 = int(rng.integers(0, _BANK - n)) if n < _BANK else 0
            img[..., 2] += bank[off2 : off2 + n].reshape(h, w) * np.float32(0.5 * look.noise_sigma)
    img += np.float32(0.5)
    np.clip(img, 0.0, 255.0, out=img)
    out: U8 = img.astype(np.uint8)
    return out
