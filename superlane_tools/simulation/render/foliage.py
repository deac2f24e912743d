"""Tree and bush crowns: per-world foliage sprites, stretched over a crown's projected box."""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from numpy.typing import NDArray

F32 = NDArray[np.float32]
F64 = NDArray[np.float64]
U8 = NDArray[np.uint8]

_SPRITE_PX = 128
SPRITE_SPAN = 1.4  # the sprite covers +-1.4 crown radii around the crown centre
_N_SPRITES = 6


@lru_cache(maxsize=4)
def crown_sprites(world_seed: int) -> tuple[tuple[F32, F32], ...]:
    """Return a few (shade, alpha) ``(128, 128)`` tree-crown sprites of a world.

    A crown is an irregular union of ellipses filled with a dark interior and covered with a
    few hundred small leaf clusters, lit from above (brighter at the top, random depth
    darkening), so trees read as foliage instead of a handful of discs.
    """
    import cv2

    rng = np.random.default_rng([world_seed, 0x7EE5])
    n = _SPRITE_PX
    scale = n / (2.0 * SPRITE_SPAN)
    out = []
    for _ in range(_N_SPRITES):
        body = np.zeros((n, n), np.uint8)
        for _ in range(int(rng.integers(3, 7))):
            c = rng.normal(0.0, 0.28, 2)
            ax = rng.uniform(0.45, 0.75, 2)
            cv2.ellipse(
                body,
                (int(n / 2 + c[0] * scale), int(n / 2 + c[1] * scale)),
                (int(ax[0] * scale), int(ax[1] * scale)),
                float(rng.uniform(0, 180)),
                0,
                360,
                1,
                -1,
            )
        shade = np.zeros((n, n), np.float32)
        alpha = np.zeros((n, n), np.float32)
        shade[body > 0] = 0.3
        alpha[body > 0] = 1.0
        ys, xs = np.nonzero(body)
        pick = rng.integers(0, ys.size, 420)
        # Back clusters first (darker), front ones last (lighter): a crude depth order.
        order = np.sort(rng.uniform(0.0, 1.0, pick.size))
        for k, depth in zip(pick, order, strict=True):
            y, x = int(ys[k]), int(xs[k])
            top = 1.0 - y / n
            val = (0.45 + 0.3 * top + 0.3 * depth) * rng.uniform(0.8, 1.1)
            rad = int(rng.uniform(2.0, 6.5))
            jx, jy = rng.normal(0.0, 3.0, 2)
            ctr = (int(x + jx), int(y + jy))
            cv2.circle(shade, ctr, rad, float(val), -1, cv2.LINE_AA)
            cv2.circle(alpha, ctr, rad, 1.0, -1, cv2.LINE_AA)
        leaf = rng.uniform(0.82, 1.12, (n, n)).astype(np.float32)
        soft = np.asarray(cv2.GaussianBlur(shade * leaf, (0, 0), 0.6), np.float32)
        out.append((soft, alpha))
    return tuple(out)


def draw_sprite(
    layers: tuple[U8, U8, F32],
    sprite: tuple[F32, F32],
    box_px: tuple[float, float, float, float],
    color: F64,
    label: int,
    depth: float,
    haze: tuple[tuple[float, float, float], float],
) -> None:
    """Draw a (shade, alpha) sprite into colour, label and depth layers over a pixel box.

    Args:
        layers: Full-frame colour (BGR), label and depth layers, modified in place.
        sprite: Shade and coverage of a crown sprite.
        box_px: Pixel box ``(u0, v0, u1, v1)`` the sprite is stretched over.
        color: Base BGR colour of the foliage (lit).
        label: Leaf id written where the coverage exceeds one half.
        depth: Distance from the camera, metres (depth layer and haze).
        haze: Airlight colour (BGR) and visibility (metres).
    """
    import cv2

    color_layer, label_layer, depth_layer = layers
    h, w = label_layer.shape
    u0, v0, u1, v1 = box_px
    x0, y0 = round(u0), round(v0)
    sw, sh = max(1, round(u1 - u0)), max(1, round(v1 - v0))
    cx0, cy0, cx1, cy1 = max(0, x0), max(0, y0), min(w, x0 + sw), min(h, y0 + sh)
    if cx1 <= cx0 or cy1 <= cy0:
        return
    shade, alpha = sprite
    interp = cv2.INTER_AREA if sw < shade.shape[1] else cv2.INTER_LINEAR
    # Crown coverage: the sprite's alpha thresholded at one half (solid foliage clusters).
    solid = cv2.resize(alpha, (sw, sh), interpolation=interp)[
        cy0 - y0 : cy1 - y0, cx0 - x0 : cx1 - x0
    ]
    mask = np.ascontiguousarray((solid > np.float32(0.5)).view(np.uint8))
    # Haze the crown's colour at its distance (light and haze act on the shaded colour as
    # c * k + airlight: fold the airlight into the shade via a per-channel offset).
    haze_bgr, vis_m = haze
    k = float(np.exp(-3.0 * min(depth, 1e5) / vis_m))
    tint = (float(color[0]) * k, float(color[1]) * k, float(color[2]) * k, 0.0)
    air = tuple(float(c) * (1.0 - k) for c in haze_bgr)
    if sw * sh < shade.size:  # colour at the smaller of the two sizes
        sh_r = np.asarray(cv2.resize(shade, (sw, sh), interpolation=interp), np.float32)
        col_r = _tinted(sh_r, tint, air)
    else:
        col_r = np.asarray(cv2.resize(_tinted(shade, tint, air), (sw, sh), interpolation=interp))
    c = np.ascontiguousarray(col_r[cy0 - y0 : cy1 - y0, cx0 - x0 : cx1 - x0])
    # cv2.copyTo with a mask is far faster than numpy's masked copies on large regions.
    cv2.copyTo(c, mask, color_layer[cy0:cy1, cx0:cx1])
    cv2.copyTo(np.full(mask.shape, label, np.uint8), mask, label_layer[cy0:cy1, cx0:cx1])
    cv2.copyTo(np.full(mask.shape, depth, np.float32), mask, depth_layer[cy0:cy1, cx0:cx1])


def _tinted(
    shade: F32, tint: tuple[float, float, float, float], air: tuple[float, ...]
) -> NDArray[np.uint8]:
    """Return ``shade * tint + air`` as 8-bit BGR."""
    import cv2

    # Per-channel scalars (tuples) are fine for OpenCV but not in its type stubs.
    col = cv2.multiply(cv2.merge([shade, shade, shade]), tint)  # type: ignore[call-overload]
    offset = (air[0], air[1], air[2], 0.0)
    out = cv2.add(col, offset, dtype=cv2.CV_8U)  # type: ignore[call-overload]
    return np.asarray(out, np.uint8)
