"""A simulated world: road, scenery, ego path and traffic; the :class:`FrameScene` at any time."""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from superlane_tools.camera.model import CameraModel
from superlane_tools.simulation.errors import ScenarioError
from superlane_tools.simulation.motion import (
    VEHICLE_SHAPES,
    EgoPath,
    EgoState,
    VehicleTrack,
    ego_path,
    ego_state,
    traffic,
)
from superlane_tools.simulation.road import Road, build_road, road_ahead
from superlane_tools.simulation.roadside import (
    Roadside,
    build_roadside,
    road_objects,
    visible_roadside,
)
from superlane_tools.simulation.scenarios import Scenario
from superlane_tools.simulation.scene import FrameScene, LaneLine, RoadProfile, SceneObject

FloatArray = NDArray[np.float64]

CORRIDOR_VIEW_M = 100.0
"""Corridor length when no vehicle blocks the ego lane, metres."""
VIEW_AHEAD_M = 200.0
"""How far ahead the road profile and objects reach, metres."""
MAX_DURATION_S = 3600.0

STREAMS = ("road", "roadside", "ego", "traffic", "sensors", "render", "camera")
"""Named random streams, each spawned from the drive seed (order is part of determinism)."""


def rng_streams(seed: int) -> dict[str, np.random.Generator]:
    """Return one independent generator per name in :data:`STREAMS`, all derived from ``seed``."""
    children = np.random.SeedSequence(seed).spawn(len(STREAMS))
    return {name: np.random.default_rng(c) for name, c in zip(STREAMS, children, strict=True)}


@dataclass(frozen=True)
class EgoLane:
    """The ego lane at one instant.

    Attributes:
        index: Lane index counted from the leftmost lane (0).
        left_line: Index into ``Road.lines`` of its left line piece.
        right_line: Index into ``Road.lines`` of its right line piece.
        width_m: Distance between the two line centres at the ego position, metres.
    """

    index: int
    left_line: int
    right_line: int
    width_m: float


@dataclass(frozen=True)
class World:
    """Everything that does not change during a drive.

    Attributes:
        scenario: The scenario it was built from.
        seed: The drive seed.
        road: The road.
        roadside: Static scenery.
        path: Ego path and speed over time.
        tracks: Other vehicles over time.
        sun_azimuth_world_rad: Sun azimuth in the world frame, radians from east.
        world_seed: Seed of the world's textures.
    """

    scenario: Scenario
    seed: int
    road: Road
    roadside: Roadside
    path: EgoPath
    tracks: tuple[VehicleTrack, ...]
    sun_azimuth_world_rad: float
    world_seed: int

    @property
    def duration_s(self) -> float:
        """Length of the planned drive, seconds."""
        return float(self.path.t_s[-1])


def build_world(scenario: Scenario, seed: int, duration_s: float) -> World:
    """Generate the world of one drive.

    Raises:
        ScenarioError: If the duration or the seed is out of range.
    """
    if not 0 < duration_s <= MAX_DURATION_S:
        raise ScenarioError(f"duration must be in (0, {MAX_DURATION_S:.0f}] s, got {duration_s}")
    if seed < 0:
        raise ScenarioError(f"seed must be non-negative, got {seed}")
    rng = rng_streams(seed)
    length = 35.0 * duration_s + VIEW_AHEAD_M + 150.0
    road = build_road(scenario.road, length, rng["road"])
    roadside = build_roadside(road, scenario.roadside, rng["roadside"])
    path = ego_path(road, rng["ego"], scenario.traffic, duration_s)
    tracks = traffic(road, path, rng["traffic"], scenario.traffic)
    heading0 = float(path.heading_rad[0])
    sun = heading0 + scenario.conditions.sun_azimuth_rad
    return World(
        scenario=scenario,
        seed=seed,
        road=road,
        roadside=roadside,
        path=path,
        tracks=tracks,
        sun_azimuth_world_rad=sun,
        world_seed=int(rng["render"].integers(2**31)),
    )


def lines_covering(lines: tuple[LaneLine, ...], s_m: float) -> list[int]:
    """Return the indices of the line pieces that exist at arc length ``s_m``."""
    return [i for i, ln in enumerate(lines) if ln.start_s_m <= s_m < ln.end_s_m]


def ego_lane(road: Road, s_m: float, lateral_m: float) -> EgoLane:
    """Find the ego lane at ``s_m`` for a vehicle at lateral offset ``lateral_m``.

    Inside an intersection (no lines at ``s_m``) the lines just beyond it are used.
    """
    probe = s_m
    idx: list[int] = []
    for probe in np.arange(s_m, s_m + 60.0, 1.0):
        idx = lines_covering(road.lines, float(probe))
        if len(idx) >= 2:
            break
    offsets = {i: float(road.lines[i].offset_at(np.array([probe]))[0]) for i in idx}
    by_offset = sorted(idx, key=lambda i: -offsets[i])
    left = [i for i in by_offset if offsets[i] >= lateral_m]
    right = [i for i in by_offset if offsets[i] < lateral_m]
    if not left:
        left, right = by_offset[:1], by_offset[1:]
    if not right:
        left, right = by_offset[:-1], by_offset[-1:]
    li, ri = left[-1], right[0]
    lane = len(left) - 1
    return EgoLane(lane, li, ri, offsets[li] - offsets[ri])


def _vehicle_objects(
    world: World, state: EgoState
) -> tuple[list[SceneObject], list[tuple[float, float, float]]]:
    """Vehicles near the ego at ``state``; also ``(l, x_rear, width)`` per vehicle."""
    t = world.path.t_s
    out: list[SceneObject] = []
    lateral: list[tuple[float, float, float]] = []
    for track in world.tracks:
        s = float(np.interp(state.t_s, t, track.s_m))
        if not state.pose.s_m - 15.0 < s < state.pose.s_m + VIEW_AHEAD_M:
            continue
        if not world.road.s_m[0] <= s <= world.road.s_m[-1]:
            continue
        lat = float(np.interp(state.t_s, t, track.l_m))
        dt = 0.2
        ds = float(np.interp(state.t_s + dt, t, track.s_m)) - s
        dl = float(np.interp(state.t_s + dt, t, track.l_m)) - lat
        offset = float(np.arctan2(dl, ds)) if abs(ds) > 1e-3 else 0.0
        if track.oncoming:
            offset += np.pi
        x, y, z, yaw = road_objects(
            world.road, state.pose, np.array([s]), np.array([lat]), np.array([offset])
        )
        length, width, height = VEHICLE_SHAPES[track.style]
        out.append(
            SceneObject(
                kind="vehicle",
                x_m=float(x[0]),
                y_m=float(y[0]),
                z_m=float(z[0]),
                length_m=length,
                width_m=width,
                height_m=height,
                yaw_rad=float(yaw[0]),
                color_bgr=track.color_bgr,
                style=track.style,
            )
        )
        lateral.append((lat, float(x[0]) - length / 2, width))
    return out, lateral


@dataclass(frozen=True)
class FrameWorld:
    """One frame of the world: the scene for the renderer plus the ego truth.

    Attributes:
        scene: What the renderer draws.
        state: Ego state.
        lane: Ego lane (indices into ``Road.lines``).
        profile_line_ids: For each line of ``scene.road.lines``, its index in ``Road.lines``.
        line_slots: For each line of ``scene.road.lines``, its slot (0 = leftmost line).
        lead_gap_m: Distance from the ego origin to the rear of the vehicle closing the
            corridor, metres (NaN if none within view).
    """

    scene: FrameScene
    state: EgoState
    lane: EgoLane
    profile_line_ids: tuple[int, ...]
    line_slots: tuple[int, ...]
    lead_gap_m: float


def frame_world(
    world: World, t_s: float, t_ns: int, camera: CameraModel, frame_seed: int
) -> FrameWorld:
    """Build the :class:`FrameScene` of the frame at ``t_s`` seconds after the start."""
    state = ego_state(world.road, world.path, t_s)
    profile: RoadProfile = road_ahead(world.road, state.pose, ahead_m=VIEW_AHEAD_M)
    lane = ego_lane(world.road, state.pose.s_m, state.lateral_m)
    ids = tuple(world.road.lines.index(ln) for ln in profile.lines)
    slots = tuple(world.road.line_slots[i] for i in ids)
    vehicles, lateral = _vehicle_objects(world, state)
    lane_center = float(np.interp(state.pose.s_m, world.road.s_m, world.path.lane_plan_m))
    gaps = [
        x_rear
        for lat, x_rear, width in lateral
        if x_rear > 0 and abs(lat - lane_center) < lane.width_m / 2 + width / 2 - 0.3
    ]
    lead_gap = min(gaps) if gaps else float("nan")
    corridor = min(CORRIDOR_VIEW_M, lead_gap) if gaps else CORRIDOR_VIEW_M
    scenery = visible_roadside(world.road, world.roadside, state.pose, ahead_m=VIEW_AHEAD_M)
    base = world.scenario.conditions
    sun_rel = (world.sun_azimuth_world_rad - state.pose.heading_rad + np.pi) % (2 * np.pi) - np.pi
    conditions = replace(base, sun_azimuth_rad=float(sun_rel))
    left = ids.index(lane.left_line) if lane.left_line in ids else 0
    right = ids.index(lane.right_line) if lane.right_line in ids else min(1, len(ids) - 1)
    scene = FrameScene(
        t_ns=t_ns,
        camera=camera,
        road=profile,
        objects=tuple(vehicles) + scenery,
        conditions=conditions,
        ego_left_line=left,
        ego_right_line=right,
        corridor_length_m=float(corridor),
        world_seed=world.world_seed,
        frame_seed=frame_seed,
    )
    return FrameWorld(scene, state, lane, ids, slots, lead_gap)
