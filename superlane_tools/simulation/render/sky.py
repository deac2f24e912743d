"""Sky, clouds, sun and the distant skyline (hills and tree line) seen above the road."""

from __future__ import annotations

from functools import lru_cache
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from superlane_tools.camera.model import CameraModel
from superlane_tools.hierarchy import LEAF_IDS
from superlane_tools.simulation.render._rays import camera_rays
from superlane_tools.simulation.render.textures import road_textures

F32 = NDArray[np.float32]
U8 = NDArray[np.uint8]

SKY = LEAF_IDS["sky"]
TERRAIN = LEAF_IDS["terrain_ground"]
VEGETATION = LEAF_IDS["vegetation"]
_SKY_AIR_M = 350.0


class SkyLayer(NamedTuple):
    """The background every ray sees when it meets neither ground nor object.

    Attributes:
        color: ``(H, W, 3)`` float32 BGR (day colours, before lighting and sensor effects).
        labels: ``(H, W)`` leaf ids: sky, or terrain/vegetation for the distant skyline.
        range_m: ``(H, W)`` distance used for haze (far for the skyline, inf for sky).
        sun_uv: Unused (None): the sun is added per frame by :func:`add_sun`.
    """

    color: F32
    labels: U8
    range_m: F32
    sun_uv: tuple[float, float] | None


def sun_direction(elevation_deg: float, azimuth_rad: float) -> NDArray[np.float64]:
    """Return the unit vector towards the sun in the vehicle frame."""
    e = np.deg2rad(elevation_deg)
    return np.array([np.cos(e) * np.cos(azimuth_rad), np.cos(e) * np.sin(azimuth_rad), np.sin(e)])


@lru_cache(maxsize=8)
def sky_layer(camera: CameraModel, world_seed: int, night: bool) -> SkyLayer:
    """Return the (cached) sky of a camera and world, without the sun (see :func:`add_sun`).

    Args:
        camera: The camera.
        world_seed: Seed of the world (clouds, skyline).
        night: Night sky (dark).
    """
    rays = camera_rays(camera)
    tex = road_textures(world_seed)
    elev, azim = rays.elevation, rays.azimuth
    e = np.clip(elev, 0.0, None)
    t = np.clip(e / 0.5, 0.0, 1.0) ** 0.6
    if night:
        horizon = np.array([48.0, 40.0, 38.0], np.float32)
        zenith = np.array([22.0, 12.0, 8.0], np.float32)
        cloud_col = np.array([40.0, 38.0, 38.0], np.float32)
    else:
        horizon = np.array([222.0, 214.0, 206.0], np.float32)
        zenith = np.array([205.0, 150.0, 105.0], np.float32)
        cloud_col = np.array([214.0, 212.0, 210.0], np.float32)
    color = horizon * (1.0 - t[..., None]) + zenith * t[..., None]
    # Clouds on a flat layer overhead: a ray at elevation e meets it cot(e) layer heights away,
    # so clouds shrink and crowd towards the horizon in both directions (no vertical streaks).
    reach = np.minimum(1.0 / np.tan(np.maximum(e, 0.004)), 60.0)
    cu = (reach * np.sin(azim) * 40.0).astype(np.int32) & 1023
    cv = (reach * np.cos(azim) * 40.0).astype(np.int32) & 255
    dens = tex.clouds[cv, cu] * np.clip(e / 0.03, 0.0, 1.0)
    shade = 1.0 - 0.25 * tex.clouds[(cv + 9) & 255, cu]
    color += dens[..., None] * (cloud_col * shade[..., None] - color)
    labels = np.full(elev.shape, SKY, np.uint8)
    rng = np.full(elev.shape, np.inf, np.float32)
    ai = ((azim + np.pi) / (2 * np.pi) * 2048).astype(np.int32) & 2047
    hills = elev < tex.skyline[ai]
    trees = elev < tex.treeline[ai]
    hill_col = horizon * 0.62 + np.array([20.0, 10.0, 0.0], np.float32)
    tree_col = horizon * 0.38 + np.array([-10.0, 5.0, -10.0], np.float32)
    rows = (elev * 2000.0).astype(np.int32) & 255
    color[hills] = (
        hill_col * (0.92 + 0.1 * tex.clouds[(rows[hills] * 3) & 255, ai[hills] & 1023])[:, None]
    )
    color[trees] = (
        tree_col * (0.85 + 0.3 * tex.clouds[(rows[trees] * 7) & 255, ai[trees] & 1023])[:, None]
    )
    labels[hills] = TERRAIN
    labels[trees] = VEGETATION
    rng[hills] = 1500.0
    rng[trees] = 800.0
    color = np.clip(color, 0.0, 255.0).astype(np.float32)
    return SkyLayer(color, labels, rng, None)


@lru_cache(maxsize=16)
def hazed_sky(
    camera: CameraModel,
    world_seed: int,
    night: bool,
    fog: float,
    haze_bgr: tuple[float, float, float],
    vis_m: float,
) -> SkyLayer:
    """Return the (cached) sky seen through fog and haze: the frame's background, without sun.

    Args:
        camera: The camera.
        world_seed: Seed of the world (clouds, skyline).
        night: Night sky.
        fog: Fog strength 0..1 (hides the skyline behind a flat bright grey).
        haze_bgr: Haze colour (BGR grey levels).
        vis_m: Meteorological visibility, metres.
    """
    sky = sky_layer(camera, world_seed, night)
    color = sky.color.copy()
    if fog > 0:
        f = np.float32(min(1.0, fog * 1.3))
        color += f * (np.float32(205.0 if not night else 40.0) - color)
    # The open sky is not a surface: haze it as if seen through a few hundred metres of air, so
    # clouds show on clear days and vanish in fog (visibility shrinks).
    seen = np.where(sky.labels == SKY, np.float32(_SKY_AIR_M), sky.range_m)
    keep = np.exp(np.minimum(seen, np.float32(1e5)) * np.float32(-3.0 / vis_m))[..., None]
    color = color * keep + (np.float32(1.0) - keep) * np.array(haze_bgr, np.float32)
    return SkyLayer(color.astype(np.float32), sky.labels, sky.range_m, None)


def add_sun(
    img: F32,
    camera: CameraModel,
    sun_elevation_deg: float,
    sun_azimuth_rad: float,
    vis_m: float,
    rows: int,
) -> tuple[float, float] | None:
    """Add the sun's glow to the top ``rows`` rows of ``img``; return the sun's image position.

    The sun moves with the vehicle's heading every frame, so it is not part of the cached sky;
    its glow is smooth (tens of pixels wide) and is evaluated at 1/8 resolution.
    """
    import cv2

    sun = sun_direction(sun_elevation_deg, sun_azimuth_rad)
    uv, front = camera.project(camera.extrinsics.position + sun[None] * 1e4)
    sun_uv = (float(uv[0, 0]), float(uv[0, 1])) if front[0] else None
    h, w = img.shape[:2]
    rows = min(rows, h)
    if rows <= 0:
        return sun_uv
    small_rows = -(-rows // 8)
    dirs = camera_rays(camera).dirs[4 : 8 * small_rows : 8, 4::8]
    cos_a = np.clip(dirs @ sun.astype(np.float32), -1.0, 1.0)
    glow = np.exp((cos_a - 1.0) / 0.004) + 0.25 * np.exp((cos_a - 1.0) / 0.05)
    glow *= np.float32(120.0 * np.exp(-3.0 * _SKY_AIR_M / vis_m))
    tinted = (glow[..., None] * np.array([0.85, 0.95, 1.0], np.float32)).astype(np.float32)
    full = cv2.resize(tinted, (w, 8 * small_rows), interpolation=cv2.INTER_LINEAR)
    cv2.add(img[:rows], full[:rows], dst=img[:rows])
    return sun_uv
