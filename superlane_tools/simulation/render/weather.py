"""Light and weather: haze and fog, night headlights, wet reflections, rain, spray, glare."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from superlane_tools.simulation.render._rays import CameraRays
from superlane_tools.simulation.render.objects import Light

F32 = NDArray[np.float32]


def visibility_m(fog: float, rain: float) -> float:
    """Return the meteorological visibility (m) for fog and rain strengths 0..1."""
    return float(2500.0 / (1.0 + 40.0 * fog**1.5 + 4.0 * rain))


def haze_keep(range_m: F32, vis_m: float) -> F32:
    """Return the fraction of scene radiance kept at ``range_m`` (Koschmieder's law)."""
    keep = np.minimum(range_m, np.float32(1e5))
    keep *= np.float32(-3.0 / vis_m)
    np.exp(keep, out=keep)
    return keep


def apply_haze(img: F32, range_m: F32, color: tuple[float, float, float], vis_m: float) -> None:
    """Blend ``img`` towards the haze ``color`` with Koschmieder's law, in place."""
    keep = haze_keep(range_m, vis_m)[..., None]
    img *= keep
    img += (np.float32(1.0) - keep) * np.array(color, np.float32)


def haze_colors(col: F32, range_m: F32, color: tuple[float, float, float], vis_m: float) -> None:
    """Haze ``(N, 3)`` colours seen at ``(N,)`` ranges (metres), in place."""
    apply_haze(col, range_m, color, vis_m)


def haze_pixels(
    img: F32,
    mask: NDArray[np.bool_],
    range_m: F32,
    color: tuple[float, float, float],
    vis_m: float,
) -> None:
    """Haze the pixels of ``img`` under ``mask`` seen at ``range_m`` (one per pixel), in place."""
    col = img[mask]
    haze_colors(col, range_m, color, vis_m)
    img[mask] = col


def headlight_gain(dir_z: F32, azimuth: F32, range_m: F32, hit: NDArray[np.bool_]) -> F32:
    """Return the ego headlight illumination (0..~1.5) of ground pixels.

    Args:
        dir_z: Vertical component of the pixel rays.
        azimuth: Ray azimuth, radians, left positive.
        range_m: Distance to the ground, metres.
        hit: Pixels whose ray meets the ground.
    """
    lateral = np.abs(azimuth) / np.float32(0.35)
    cone = np.exp(-(lateral * lateral))
    # Low-beam cut-off: light falls off beyond ~60 m; 1/r^2 near, clamped.
    r = np.maximum(range_m, np.float32(4.0))
    fall = np.float32(150.0) / (r * r + np.float32(100.0))
    gain = cone * np.minimum(fall, np.float32(1.5)) * (dir_z < 0)
    out: F32 = np.where(hit, gain, np.float32(0.0)).astype(np.float32)
    return out


def wet_reflection(img: F32, rays: CameraRays, gloss: F32, row0: int, wet: float) -> None:
    """Mirror the scene above the horizon into glossy ground pixels (blurred), in place."""
    import cv2

    src = cv2.GaussianBlur(img, (0, 0), 1.2 + 2.0 * (1.0 - wet))
    mu, mv = rays.mirror_u[row0:], rays.mirror_v[row0:]
    refl = cv2.remap(src, mu, mv, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    # Streak the reflections vertically like a real wet road (micro-ripples).
    refl = cv2.blur(refl, (3, 15))
    # Fade out where the mirrored direction leaves the image (no hard reflection border).
    w = img.shape[1]
    edge = np.clip(mv / np.float32(80.0), 0.0, 1.0) * np.clip(
        np.minimum(mu, np.float32(w - 1) - mu) / np.float32(60.0), 0.0, 1.0
    )
    a = gloss * np.float32(0.45) * edge
    part = img[row0:]
    part += a[..., None] * (refl - part)


def add_lights(img: F32, lights: list[Light], strength: float) -> None:
    """Add glowing light sources (tail lights, lamps) with a soft halo, in place."""
    import cv2

    if not lights:
        return
    h, w = img.shape[:2]
    glow = np.zeros((h // 4, w // 4, 3), np.float32)
    for lt in lights:
        c = (int(lt.u / 4 * 16), int(lt.v / 4 * 16))
        rad = int(max(1.0, lt.radius_px * 1.5) / 4 * 16) + 16
        col = tuple(float(x * lt.intensity * strength) for x in lt.color_bgr)
        cv2.circle(glow, c, rad, col, -1, cv2.LINE_AA, 4)
    glow = cv2.GaussianBlur(glow, (0, 0), 3.0)
    img += cv2.resize(glow, (w, h), interpolation=cv2.INTER_LINEAR)


def add_glare(img: F32, sun_uv: tuple[float, float] | None, glare: float, elev_deg: float) -> None:
    """Add veiling glare, a bloom around the sun and lens-flare ghosts, in place."""
    import cv2

    h, w = img.shape[:2]
    veil = np.float32(40.0 * glare)
    img += veil
    if sun_uv is None:
        return
    u, v = sun_uv
    if not (-0.5 * w < u < 1.5 * w and -0.5 * h < v < 1.5 * h):
        return
    small = np.zeros((h // 4, w // 4), np.float32)
    cv2.circle(small, (int(u / 4 * 16), int(v / 4 * 16)), 6 * 16, 1.0, -1, cv2.LINE_AA, 4)
    bloom = cv2.GaussianBlur(small, (0, 0), 25.0) * 8.0 + cv2.GaussianBlur(small, (0, 0), 4.0)
    # Ghosts on the line through the image centre.
    ghosts = np.zeros_like(small)
    cx, cy = w / 2, h / 2
    for k, rad in ((-0.4, 10), (-0.9, 18), (0.5, 6), (-1.4, 28)):
        gu, gv = cx + k * (u - cx), cy + k * (v - cy)
        cv2.circle(ghosts, (int(gu / 4 * 16), int(gv / 4 * 16)), rad * 16, 0.12, -1, cv2.LINE_AA, 4)
    ghosts = cv2.GaussianBlur(ghosts, (0, 0), 2.0)
    low = np.float32(1.0 + 1.5 * np.clip((20.0 - elev_deg) / 20.0, 0.0, 1.0))
    tot = cv2.resize(bloom * low + ghosts, (w, h), interpolation=cv2.INTER_LINEAR)
    img += (tot * np.float32(255.0 * glare))[..., None] * np.array([0.8, 0.95, 1.0], np.float32)


def add_rain(img: F32, rng: np.random.Generator, rain: float) -> None:
    """Add rain streaks and out-of-focus droplets on the windscreen, in place."""
    import cv2

    h, w = img.shape[:2]
    streaks = np.zeros((h // 2, w // 2), np.float32)
    n = int(300 * rain)
    xs = rng.uniform(0, w / 2, n)
    ys = rng.uniform(0, h / 2, n)
    ln = rng.uniform(6, 22, n)
    ang = rng.normal(1.45, 0.06, n)
    for x, y, L, a in zip(xs, ys, ln, ang, strict=True):
        x2, y2 = x + L * np.cos(a), y + L * np.sin(a)
        cv2.line(streaks, (int(x), int(y)), (int(x2), int(y2)), 0.5, 1, cv2.LINE_AA)
    streaks = cv2.GaussianBlur(streaks, (0, 0), 0.7)
    img += (cv2.resize(streaks, (w, h)) * np.float32(70.0 * rain))[..., None]
    # Droplets: local blurred, slightly brighter, refracted patches.
    blurred = cv2.GaussianBlur(img, (0, 0), 6.0)
    mask = np.zeros((h, w), np.float32)
    for _ in range(int(40 * rain)):
        cx, cy = int(rng.uniform(0, w)), int(rng.uniform(0, h))
        r = int(rng.uniform(6, 28))
        cv2.ellipse(
            mask, (cx, cy), (r, int(r * rng.uniform(0.7, 1.0))), 0, 0, 360, 1.0, -1, cv2.LINE_AA
        )
    soft = cv2.GaussianBlur(mask, (0, 0), 2.0)[..., None]
    img += soft * (blurred * np.float32(1.08) - img)


def add_spray(img: F32, box_uv: tuple[float, float, float, float] | None, rain: float) -> None:
    """Add a grey spray cloud behind a preceding vehicle's image box ``(u0, v0, u1, v1)``."""
    import cv2

    if box_uv is None:
        return
    h, w = img.shape[:2]
    u0, v0, u1, v1 = box_uv
    mask = np.zeros((h // 4, w // 4), np.float32)
    bw = u1 - u0
    cu, cv_ = (u0 + u1) / 2, v1 - 0.15 * (v1 - v0)
    cv2.ellipse(
        mask,
        (int(cu / 4), int(cv_ / 4)),
        (int(bw * 0.75 / 4) + 1, int(bw * 0.3 / 4) + 1),
        0,
        0,
        360,
        1.0,
        -1,
    )
    mask = cv2.GaussianBlur(mask, (0, 0), max(1.0, bw / 20))
    mask = cv2.resize(mask, (w, h))[..., None] * np.float32(0.6 * rain)
    img += mask * (np.float32(175.0) - img)
