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
    """Mirror the scene above the horizon into glossy ground pixels (blurred), in place.

    The reflection is blurry anyway, so it is built at half resolution and resized up.
    """
    import cv2

    h, w = img.shape[:2]
    w2, h2 = (w + 1) // 2, (h + 1) // 2
    small = cv2.resize(img, (w2, h2), interpolation=cv2.INTER_AREA)
    src = cv2.GaussianBlur(small, (0, 0), 0.5 * (1.2 + 2.0 * (1.0 - wet)))
    # Half-resolution source coordinates of the full-resolution mirror maps (every 2nd pixel).
    mu = rays.mirror_u[row0::2, ::2] * np.float32(0.5) - np.float32(0.25)
    mv = rays.mirror_v[row0::2, ::2] * np.float32(0.5) - np.float32(0.25)
    refl_h = cv2.remap(src, mu, mv, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    # Streak the reflections vertically like a real wet road (micro-ripples).
    refl_h = cv2.blur(refl_h, (2, 8))
    rows = h - row0
    refl = np.asarray(cv2.resize(refl_h, (w, rows), interpolation=cv2.INTER_LINEAR), np.float32)
    a = gloss * rays.mirror_fade[row0:]
    a *= np.float32(0.45)
    part = img[row0:]
    refl -= part
    refl *= a[..., None]
    part += refl


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
    veil = float(40.0 * glare)
    if sun_uv is None or not (-0.5 * w < sun_uv[0] < 1.5 * w and -0.5 * h < sun_uv[1] < 1.5 * h):
        img += np.float32(veil)
        return
    u, v = sun_uv
    # Bloom and ghosts are smooth: draw them at 1/4 (ghosts) and 1/16 (wide bloom) resolution.
    small = np.zeros((h // 4, w // 4), np.float32)
    cv2.circle(small, (int(u / 4 * 16), int(v / 4 * 16)), 6 * 16, 1.0, -1, cv2.LINE_AA, 4)
    tiny = cv2.resize(small, (w // 16, h // 16), interpolation=cv2.INTER_AREA)
    wide = cv2.resize(cv2.GaussianBlur(tiny, (0, 0), 25.0 / 4.0), (w // 4, h // 4))
    bloom = wide * np.float32(8.0) + cv2.GaussianBlur(small, (0, 0), 4.0)
    # Ghosts on the line through the image centre.
    ghosts = np.zeros_like(small)
    cx, cy = w / 2, h / 2
    for k, rad in ((-0.4, 10), (-0.9, 18), (0.5, 6), (-1.4, 28)):
        gu, gv = cx + k * (u - cx), cy + k * (v - cy)
        cv2.circle(ghosts, (int(gu / 4 * 16), int(gv / 4 * 16)), rad * 16, 0.12, -1, cv2.LINE_AA, 4)
    ghosts = cv2.GaussianBlur(ghosts, (0, 0), 2.0)
    low = np.float32(1.0 + 1.5 * np.clip((20.0 - elev_deg) / 20.0, 0.0, 1.0))
    tot = (bloom * low + ghosts) * np.float32(255.0 * glare)
    tot += np.float32(veil)  # the veil rides along in the same pass (colour-tinted slightly)
    full = cv2.resize(tot, (w, h), interpolation=cv2.INTER_LINEAR)
    tint = cv2.multiply(  # type: ignore[call-overload]  # a per-channel scalar
        cv2.cvtColor(full, cv2.COLOR_GRAY2BGR), (0.8, 0.95, 1.0, 0.0)
    )
    cv2.add(img, tint, dst=img)


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
    x2s, y2s = xs + ln * np.cos(ang), ys + ln * np.sin(ang)
    for x, y, x2, y2 in zip(xs.tolist(), ys.tolist(), x2s.tolist(), y2s.tolist(), strict=True):
        cv2.line(streaks, (int(x), int(y)), (int(x2), int(y2)), 0.5, 1, cv2.LINE_AA)
    streaks = cv2.GaussianBlur(streaks, (0, 0), 0.7) * np.float32(70.0 * rain)
    full = cv2.resize(streaks, (w, h))
    cv2.add(img, cv2.cvtColor(full, cv2.COLOR_GRAY2BGR), dst=img)
    # Droplets: local blurred, slightly brighter, refracted patches (blurred at 1/4 size).
    small = cv2.resize(img, (w // 4, h // 4), interpolation=cv2.INTER_AREA)
    blurred = np.asarray(cv2.resize(cv2.GaussianBlur(small, (0, 0), 1.5), (w, h)), np.float32)
    blurred *= np.float32(1.08)
    for _ in range(int(40 * rain)):
        cx, cy = int(rng.uniform(0, w)), int(rng.uniform(0, h))
        r = int(rng.uniform(6, 28))
        ry = int(r * rng.uniform(0.7, 1.0))
        m = r + 6  # soft edge margin
        x0, y0, x1, y1 = max(0, cx - m), max(0, cy - m), min(w, cx + m + 1), min(h, cy + m + 1)
        if x1 <= x0 or y1 <= y0:
            continue
        mask = np.zeros((y1 - y0, x1 - x0), np.float32)
        cv2.ellipse(mask, (cx - x0, cy - y0), (r, ry), 0, 0, 360, 1.0, -1, cv2.LINE_AA)
        soft = cv2.GaussianBlur(mask, (0, 0), 2.0)[..., None]
        roi = img[y0:y1, x0:x1]
        roi += soft * (blurred[y0:y1, x0:x1] - roi)


def add_spray(img: F32, box_uv: tuple[float, float, float, float] | None, rain: float) -> None:
    """Add a grey spray cloud behind a preceding vehicle's image box ``(u0, v0, u1, v1)``."""
    import cv2

    if box_uv is None:
        return
    h, w = img.shape[:2]
    u0, v0, u1, v1 = box_uv
    bw = u1 - u0
    cu, cv_ = (u0 + u1) / 2, v1 - 0.15 * (v1 - v0)
    ax, ay = bw * 0.75 + 4, bw * 0.3 + 4
    sigma = max(1.0, bw / 20)
    # Work only in the cloud's box (ellipse plus three blur sigmas), at 1/4 resolution.
    pad = 3 * 4 * sigma
    x0, x1 = max(0, int(cu - ax - pad)), min(w, int(cu + ax + pad) + 1)
    y0, y1 = max(0, int(cv_ - ay - pad)), min(h, int(cv_ + ay + pad) + 1)
    if x1 - x0 < 8 or y1 - y0 < 8:
        return
    sw, sh = (x1 - x0) // 4 + 1, (y1 - y0) // 4 + 1
    mask = np.zeros((sh, sw), np.float32)
    centre = (int((cu - x0) / 4), int((cv_ - y0) / 4))
    cv2.ellipse(mask, centre, (int(bw * 0.75 / 4) + 1, int(bw * 0.3 / 4) + 1), 0, 0, 360, 1.0, -1)
    mask = cv2.GaussianBlur(mask, (0, 0), sigma)
    alpha = cv2.resize(mask, (sw * 4, sh * 4))[: y1 - y0, : x1 - x0, None]
    alpha = alpha * np.float32(0.6 * rain)
    roi = img[y0:y1, x0:x1]
    roi += alpha * (np.float32(175.0) - roi)
