"""Render one :class:`~superlane_tools.simulation.scene.FrameScene`: image, labels, corridor."""

from __future__ import annotations

import time
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from superlane_tools.simulation.errors import ScenarioError
from superlane_tools.simulation.render import weather
from superlane_tools.simulation.render._rays import CameraRays, camera_rays
from superlane_tools.simulation.render.objects import Layers, draw_objects, shadow_factor
from superlane_tools.simulation.render.raycast import (
    RoadHit,
    RoadTables,
    cast_road,
    road_coordinates,
    road_tables,
)
from superlane_tools.simulation.render.road_shading import (
    DRIVABLE_IDS,
    Ground,
    GroundLight,
    line_offset,
    shade_ground,
)
from superlane_tools.simulation.render.sensor import finish, look_for
from superlane_tools.simulation.render.sky import add_sun, hazed_sky
from superlane_tools.simulation.render.textures import road_textures
from superlane_tools.simulation.render.tunnel import WALL, draw_tunnel
from superlane_tools.simulation.scene import Conditions, FrameScene, RenderedFrame, SceneObject

F32 = NDArray[np.float32]

_DRIVABLE_LUT = np.zeros(256, np.uint8)
_DRIVABLE_LUT[list(DRIVABLE_IDS)] = 1


class _StageClock:
    """Adds the CPU time (ms) of consecutive render stages to a dict (no-op without one)."""

    def __init__(self, out: dict[str, float] | None) -> None:
        self.out = out
        self.t = time.thread_time() if out is not None else 0.0

    def __call__(self, stage: str) -> None:
        if self.out is not None:
            t = time.thread_time()
            self.out[stage] = self.out.get(stage, 0.0) + (t - self.t) * 1e3
            self.t = t


def render(scene: FrameScene, stage_ms: dict[str, float] | None = None) -> RenderedFrame:
    """Render ``scene`` into a BGR image, a leaf-id label image and the ego-corridor mask.

    The same scene always gives byte-identical output: every random choice is drawn from
    ``world_seed`` (textures, skyline, object details) or ``frame_seed`` (noise, rain).

    Args:
        scene: The frame to draw.
        stage_ms: If given, CPU milliseconds of each stage (``ray_cast``, ``objects``,
            ``road_shading``, ``composite``, ``effects``, ``sensor``) are added to it.

    Raises:
        ScenarioError: If the scene is inconsistent (bad profile, ego line indices).
    """
    clock = _StageClock(stage_ms)
    road, cond, cam = scene.road, scene.conditions, scene.camera
    _check_ego_lines(scene)
    rng = np.random.default_rng([scene.world_seed, scene.frame_seed, 0xF7A3E])
    look = look_for(cond, rng)
    rays = camera_rays(cam)
    tables = road_tables(road)
    hit = cast_road(rays, tables)
    clock("ray_cast")
    tex = road_textures(scene.world_seed)
    row0 = hit.row0

    night = cond.daylight < 0.25 or cond.tunnel
    vis = weather.visibility_m(cond.fog, cond.rain)
    hz = _haze_bgr(cond, night)
    sky = hazed_sky(cam, scene.world_seed, night, cond.fog, hz, vis)
    img = sky.color.copy()
    sun_uv = (
        None
        if night
        else add_sun(img, cam, cond.sun_elevation_deg, cond.sun_azimuth_rad, vis, row0 + 8)
    )
    canvas = _Canvas(img, sky.labels.copy(), sky.range_m.copy())
    clock("composite")
    layers = draw_objects(cam, scene.objects, cond.daylight, scene.world_seed, hz, vis)
    clock("objects")

    light = _ground_light(scene, rays, hit, layers, night, hz, vis)
    # Raised pavement markers (Botts' dots) are a property of the world: half of them have them.
    dots = scene.world_seed % 2 == 1
    ground = shade_ground(
        hit, road, tex, look.palette, cond.cracks, cond.tar_seams, cond.wet, light, img[row0:], dots
    )
    clock("road_shading")
    gh = _paste_ground(canvas, sky.color, ground, hit)
    if cond.tunnel:
        gh = _paste_tunnel(canvas, scene, rays, tables, hit, hz, vis)
    _paste_objects(canvas, scene, layers, ground, gh, rays, row0)
    corridor = _corridor(scene, tables, hit, gh, canvas.labels)

    # Lights, weather, sensor.
    clock("composite")
    _add_effects(img, scene, layers, sun_uv, night, rng)
    clock("effects")
    image = finish(img, rays.vignette, cond, look, rng)
    clock("sensor")
    return RenderedFrame(image_bgr=image, labels=canvas.labels, corridor=corridor)


class _Canvas(NamedTuple):
    """The full frame being composited: BGR image, leaf-id labels and range (m) per pixel."""

    img: F32
    labels: NDArray[np.uint8]
    range_m: F32


def _check_ego_lines(scene: FrameScene) -> None:
    """Raise :class:`ScenarioError` unless the ego lane's line indices exist in the road."""
    n_lines = len(scene.road.lines)
    if not (0 <= scene.ego_left_line < n_lines and 0 <= scene.ego_right_line < n_lines):
        raise ScenarioError(
            f"ego lines {scene.ego_left_line}, {scene.ego_right_line} out of range "
            f"for {n_lines} lines"
        )


def _haze_bgr(cond: Conditions, night: bool) -> tuple[float, float, float]:
    """Return the airlight colour (BGR grey levels), dimmed with the daylight."""
    base = (205.0, 200.0, 196.0) if not night else (30.0, 28.0, 28.0)
    dim = 0.5 + 0.5 * min(1.0, cond.daylight)
    return (base[0] * dim, base[1] * dim, base[2] * dim)


def _ground_light(
    scene: FrameScene,
    rays: CameraRays,
    hit: RoadHit,
    layers: Layers,
    night: bool,
    hz: tuple[float, float, float],
    vis: float,
) -> GroundLight:
    """Return the ground light on the half grid.

    Daylight ambient, headlights at night, object contact shadows, then haze; the ground is
    shaded with it straight into the frame's rows below ``row0``.
    """
    cond, row0 = scene.conditions, hit.row0
    range_h, hit_h = hit.range_m[::2, ::2], hit.hit[::2, ::2]
    amb = np.float32(0.4 + 0.6 * min(1.0, cond.daylight)) if not cond.tunnel else np.float32(0.45)
    keep = weather.haze_keep(range_h, vis)
    airlight = np.float32(1.0) - keep
    if night:
        head = weather.headlight_gain(
            rays.dirs[row0::2, ::2, 2], rays.azimuth[row0::2, ::2], range_h, hit_h
        )
        keep *= amb + head * np.float32(0.9)
    else:
        keep *= amb
    if scene.objects:
        keep *= shadow_factor(layers.shadow, row0, keep.shape, 0.45 + 0.3 * cond.daylight)
    return GroundLight(keep, airlight, hz)


def _paste_ground(canvas: _Canvas, sky_bgr: F32, ground: Ground, hit: RoadHit) -> NDArray[np.bool_]:
    """Put the ground's labels and ranges below the horizon; return where rays hit the ground.

    The ground colour is already in place (shaded into the image); rows where some rays miss
    the ground get the sky back there.
    """
    import cv2

    img, labels, range_m = canvas
    row0 = hit.row0
    gh = hit.hit
    misses = np.flatnonzero(~gh.all(axis=1))
    if misses.size:  # rows where some rays miss the ground keep the sky there
        a, b = int(misses[0]), int(misses[-1]) + 1
        miss = (~gh[a:b]).view(np.uint8)
        cv2.copyTo(sky_bgr[row0 + a : row0 + b], miss, img[row0 + a : row0 + b])
    gh8 = gh.view(np.uint8)
    cv2.copyTo(ground.labels, gh8, labels[row0:])
    cv2.copyTo(hit.range_m, gh8, range_m[row0:])
    return gh


def _paste_tunnel(
    canvas: _Canvas,
    scene: FrameScene,
    rays: CameraRays,
    tables: RoadTables,
    hit: RoadHit,
    hz: tuple[float, float, float],
    vis: float,
) -> NDArray[np.bool_]:
    """Draw the tunnel walls and ceiling (hazed); return the ground mask of rows ``row0:`` left."""
    img, labels, range_m = canvas
    row0 = hit.row0
    ground_mask = np.zeros((scene.camera.height, scene.camera.width), bool)
    ground_mask[row0:] = hit.hit
    draw_tunnel(img, labels, range_m, ground_mask, rays, tables, scene.road, hit)
    walls = labels == WALL
    weather.haze_pixels(img, walls, range_m[walls], hz, vis)
    return ground_mask[row0:]


def _paste_objects(
    canvas: _Canvas,
    scene: FrameScene,
    layers: Layers,
    ground: Ground,
    gh: NDArray[np.bool_],
    rays: CameraRays,
    row0: int,
) -> None:
    """Composite the objects by depth, then the reflections of the uncovered glossy ground.

    The road occludes objects beyond a crest; objects are already hazed per pixel.
    """
    import cv2

    img, labels, range_m = canvas
    cond = scene.conditions
    occl = layers.labels > 0
    occl &= layers.depth < range_m
    if scene.objects:
        occl8 = occl.view(np.uint8)
        cv2.copyTo(layers.color.astype(np.float32), occl8, img)
        cv2.copyTo(layers.labels, occl8, labels)
    if cond.wet > 0 or cond.tar_seams > 0:
        gloss = ground.gloss * gh
        gloss *= ~occl[row0:]
        if cond.wet > 0:
            weather.wet_reflection(img, rays, gloss, row0, cond.wet)
        else:
            gloss *= np.float32(0.5)
            weather.wet_reflection(img, rays, gloss, row0, 0.3)


def _corridor(
    scene: FrameScene,
    tables: RoadTables,
    hit: RoadHit,
    gh: NDArray[np.bool_],
    labels: NDArray[np.uint8],
) -> NDArray[np.bool_]:
    """Return the ego corridor: drivable pixels between the ego lane's line centres.

    It ends ``scene.corridor_length_m`` (arc length) ahead of the ego position.
    """
    import cv2

    road, row0 = scene.road, hit.row0
    s_ego = float(road_coordinates(tables, np.zeros(1, np.float32), np.zeros(1, np.float32))[0][0])
    lo_line, hi_line = road.lines[scene.ego_right_line], road.lines[scene.ego_left_line]
    lo = line_offset(lo_line, hit.s_m)
    hi = line_offset(hi_line, hit.s_m)
    lo, hi = np.minimum(lo, hi), np.maximum(lo, hi)
    corridor = np.zeros((scene.camera.height, scene.camera.width), bool)
    corridor[row0:] = (
        gh
        & (hit.l_m >= lo)
        & (hit.l_m <= hi)
        & (hit.s_m - np.float32(s_ego) < np.float32(scene.corridor_length_m))
        & (hit.x_m > 0)
    )
    corridor &= cv2.LUT(labels, _DRIVABLE_LUT).view(bool)
    return corridor


def _add_effects(
    img: F32,
    scene: FrameScene,
    layers: Layers,
    sun_uv: tuple[float, float] | None,
    night: bool,
    rng: np.random.Generator,
) -> None:
    """Add the light sources' glow, spray and rain (draws from ``rng``) and the sun's glare."""
    cond = scene.conditions
    if night or cond.fog > 0.3 or cond.rain > 0.3:
        weather.add_lights(img, layers.lights, 0.8 if night else 0.4)
    if cond.rain > 0:
        weather.add_spray(img, _lead_box(scene), cond.rain)
        weather.add_rain(img, rng, cond.rain)
    if cond.glare > 0:
        weather.add_glare(img, sun_uv, cond.glare, cond.sun_elevation_deg)


def _lead_box(scene: FrameScene) -> tuple[float, float, float, float] | None:
    """Return the image box of the nearest vehicle ahead in the ego lane, or None."""
    best: SceneObject | None = None
    for o in scene.objects:
        if (
            o.kind == "vehicle"
            and o.x_m > 3.0
            and abs(o.y_m) < 2.0
            and (best is None or o.x_m < best.x_m)
        ):
            best = o
    if best is None:
        return None
    c, s = np.cos(best.yaw_rad), np.sin(best.yaw_rad)
    pts = [
        [
            best.x_m + c * a * best.length_m - s * b * best.width_m,
            best.y_m + s * a * best.length_m + c * b * best.width_m,
            best.z_m + z,
        ]
        for a in (-0.5, 0.5)
        for b in (-0.5, 0.5)
        for z in (0.0, best.height_m)
    ]
    uv, front = scene.camera.project(np.array(pts))
    if not np.all(front):
        return None
    return (
        float(uv[:, 0].min()),
        float(uv[:, 1].min()),
        float(uv[:, 0].max()),
        float(uv[:, 1].max()),
    )
