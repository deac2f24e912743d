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
    # Grey surfaces (pavement, paint, sidewalks) keep a near-neutral hue: a strong per-channel
    # tint turns whole roads pink or green, which no camera sees; vegetation varies more.
    palette = Palette(
        asphalt=jit(p.asphalt, 4.0),
        concrete=jit(p.concrete, 5.0),
        white_paint=jit(p.white_paint, 4.0),
        yellow_paint=jit(p.yellow_paint, 15.0),
        grass=jit(p.grass, 18.0),
        dirt=jit(p.dirt, 12.0),
        sidewalk=jit(p.sidewalk, 5.0),
        seam=jit(p.seam, 3.0),
    )
    g = np.exp(rng.normal(0.0, 0.08 * r, 3))
    return Look(
        palette,
        (float(g[0]), float(g[1]), float(g[2])),
        float(np.exp(rng.normal(0.0, 0.15 * r))),
        float(rng.normal(0.0, 12.0 * r)),
        float(cond.noise_sigma * np.exp(rng.normal(0.0, 0.5 * r))),
    )


_OFFSETS = 1 << 18


@lru_cache(maxsize=2)
def _noise_bank(pixels: int) -> F32:
    """Return a fixed bank of BGR sensor noise for images of ``pixels`` pixels.

    Rows of ``(pixels + _OFFSETS, 3)`` standard-normal luminance noise shared by the three
    channels plus half as much chroma noise on red; a frame reads ``pixels`` rows from a
    random offset (drawn from its seed), so no frame pays for fresh normal samples.
    """
    rng = np.random.default_rng(0x5E75)
    n = pixels + _OFFSETS
    bank = np.empty((n, 3), np.float32)
    lum = rng.standard_normal(n, dtype=np.float32)
    bank[:, 0] = lum
    bank[:, 1] = lum
    bank[:, 2] = lum + np.float32(0.5) * rng.standard_normal(n, dtype=np.float32)
    return bank


_VIGNETTE3: dict[int, tuple[F32, F32]] = {}


def _vignette3(vignette: F32) -> F32:
    """Return ``vignette`` repeated over three channels (kept while the ray grid lives)."""
    hit = _VIGNETTE3.get(id(vignette))
    if hit is not None and hit[0] is vignette:
        return hit[1]
    if len(_VIGNETTE3) >= 4:
        _VIGNETTE3.clear()
    out: F32 = np.ascontiguousarray(np.repeat(vignette[..., None], 3, axis=2))
    _VIGNETTE3[id(vignette)] = (vignette, out)
    return out


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
        _motion_blur(img, cond.motion_blur_px)
    cv2.multiply(img, _vignette3(vignette), dst=img, scale=float(cond.exposure))
    if look.gain_bgr != (1.0, 1.0, 1.0):
        g = look.gain_bgr
        cv2.multiply(img, (g[0], g[1], g[2], 0.0), dst=img)  # type: ignore[call-overload]
    if look.contrast != 1.0 or look.brightness != 0.0:
        # Contrast about mid-grey 128, then brightness.
        off = 128.0 * (1.0 - look.contrast) + look.brightness
        cv2.addWeighted(img, look.contrast, img, 0.0, off, dst=img)
    sigma = float(look.noise_sigma)
    if sigma > 0:
        n = h * w
        bank = _noise_bank(n)
        off = int(rng.integers(0, _OFFSETS))
        noise = bank[off : off + n].reshape(h, w, 3)
        out = cv2.addWeighted(img, 1.0, noise, sigma, 0.0, dtype=cv2.CV_8U)
    else:
        out = cv2.addWeighted(img, 1.0, img, 0.0, 0.0, dtype=cv2.CV_8U)
    result: U8 = np.asarray(out, dtype=np.uint8)
    return result


def _motion_blur(img: F32, length_px: float) -> None:
    """Blur ``img`` vertically/horizontally by up to ``length_px``, growing towards the bottom."""
    import cv2

    h, w = img.shape[:2]
    k = round(length_px)
    small = cv2.resize(img, (w // 2, h // 2), interpolation=cv2.INTER_AREA)
    small = cv2.blur(small, (max(1, k // 4), max(1, k // 2)))
    blurred = np.asarray(cv2.resize(small, (w, h), interpolation=cv2.INTER_LINEAR), np.float32)
    # Motion blur grows towards the image bottom (closer, faster-moving road).
    wgt = np.linspace(0.0, 1.0, h, dtype=np.float32)[:, None, None]
    blurred -= img
    blurred *= wgt
    img += blurred
