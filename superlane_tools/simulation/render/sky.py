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
        sun_uv: Image position of the sun (may lie outside the image), or None behind.
    """

    color: F32
    labels: U8
    range_m: F32
    sun_uv: tuple[float, float] | None


def sun_direction(elevation_deg: float, azimuth_rad: float) -> NDArray[np.float64]:
    """Return the unit vector towards the sun in the vehicle frame."""
    e = np.deg2rad(elevation_deg)
    return np.array([np.cos(e) * np.cos(azimuth_rad), np.cos(e) * np.sin(azimuth_rad), np.sin(e)])


@lru_cache(maxsize=16)
def sky_layer(
    camera: CameraModel,
    world_seed: int,
    sun_elevation_deg: float,
    sun_azimuth_rad: float,
    night: bool,
) -> SkyLayer:
    """Return the (cached) sky of a camera, world and sun position.

    Args:
        camera: The camera.
        world_seed: Seed of the world (clouds, skyline).
        sun_elevation_deg: Sun elevation, degrees.
        sun_azimuth_rad: Sun azimuth, radians, left positive.
        night: Night sky (dark, no sun disc).
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
    # Clouds on a dome: rows compress towards the horizon.
    cv = np.clip((0.06 / (e + 0.06)) * 255.0, 0, 255).astype(np.int32)
    cu = ((azim / (2 * np.pi)) * 4096.0).astype(np.int32) & 1023
    dens = tex.clouds[255 - cv, cu] * np.clip(e / 0.02, 0.0, 1.0)
    shade = 1.0 - 0.25 * tex.clouds[(255 - cv + 9) & 255, cu]
    color += dens[..., None] * (cloud_col * shade[..., None] - color)
    sun = sun_direction(sun_elevation_deg, sun_azimuth_rad)
    sun_uv: tuple[float, float] | None = None
    if not night:
        cos_a = np.clip(rays.dirs @ sun.astype(np.float32), -1.0, 1.0)
        glow = np.exp((cos_a - 1.0) / 0.004) + 0.25 * np.exp((cos_a - 1.0) / 0.05)
        color += (glow * 120.0)[..., None] * np.array([0.85, 0.95, 1.0], np.float32)
        uv, front = camera.project(camera.extrinsics.position + sun[None] * 1e4)
        if front[0]:
            sun_uv = (float(uv[0, 0]), float(uv[0, 1]))
    labels = np.full(elev.shape, SKY, np.uint8)
    rng = np.full(elev.shape, np.inf, np.float32)
    ai = ((azim + np.pi) / (2 * np.pi) * 2048).astype(np.int32) & 2047
    hills = elev < tex.skyline[ai]
    trees = elev < tex.treeline[ai]
    hill_col = horizon * 0.62 + np.array([20.0, 10.0, 0.0], np.float32)
    tree_col = horizon * 0.38 + np.array([-10.0, 5.0, -10.0], np.float32)
    color[hills] = hill_col * (0.92 + 0.1 * tex.clouds[(cv[hills] * 3) & 255, cu[hills]])[:, None]
    color[trees] = tree_col * (0.85 + 0.3 * tex.clouds[(cv[trees] * 7) & 255, cu[trees]])[:, None]
    labels[hills] = TERRAIN
    labels[trees] = VEGETATION
    rng[hills] = 1500.0
    rng[trees] = 800.0
    color = np.clip(color, 0.0, 255.0).astype(np.float32)
    return SkyLayer(color, labels, rng, sun_uv)


@lru_cache(maxsize=16)
def hazed_sky(
    camera: CameraModel,
    world_seed: int,
    sun_elevation_deg: float,
    sun_azimuth_rad: float,
    night: bool,
    fog: float,
    haze_bgr: tuple[float, float, float],
    vis_m: float,
) -> SkyLayer:
    """Return the (cached) sky seen through fog and haze: the frame's background.

    Args:
        camera: The camera.
        world_seed: Seed of the world (clouds, skyline).
        sun_elevation_deg: Sun elevation, degrees.
        sun_azimuth_rad: Sun azimuth, radians, left positive.
        night: Night sky.
        fog: Fog strength 0..1 (hides the skyline behind a flat bright grey).
        haze_bgr: Haze colour (BGR grey levels).
        vis_m: Meteorological visibility, metres.
    """
    sky = sky_layer(camera, world_seed, sun_elevation_deg, sun_azimuth_rad, night)
    color = sky.color.copy()
    if fog > 0:
        f = np.float32(min(1.0, fog * 1.3))
        color += f * (np.float32(205.0 if not night else 40.0) - color)
    # The open sky is not a surface: haze it as if seen through a few hundred metres of air, so
    # clouds show on clear days and vanish in fog (visibility shrinks).
    seen = np.where(sky.labels == SKY, np.float32(_SKY_AIR_M), sky.range_m)
    keep = np.exp(np.minimum(seen, np.float32(1e5)) * np.float32(-3.0 / vis_m))[..., None]
    color = color * keep + (np.float32(1.0) - keep) * np.array(haze_bgr, np.float32)
    return SkyLayer(color.astype(np.float32), sky.labels, sky.range_m, sky.sun_uv)
