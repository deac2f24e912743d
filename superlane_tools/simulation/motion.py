"""Ego motion and traffic: speed profile, lane keeping with wander, lane changes, other vehicles.

The ego path is defined over the road's arc length ``s``: its lateral offset ``l(s)`` is the
centre of the planned lane (lane changes as C2-smooth quintic steps over 80-130 m) plus a slow
wander of a few decimetres. Its world positions, heading and curvature are derived from that
path on the road's dense grid, so yaw rate (``curvature * speed``) and path curvature are
consistent with the road by construction. Time integration is on a 10 ms grid.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from superlane_tools.simulation.road import EgoPose, Road

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

TIME_STEP_S = 0.01
"""Step of the motion tables, seconds."""
MIN_SPEED_MPS = 5.0
MAX_SPEED_MPS = 35.0

VEHICLE_SHAPES: dict[str, tuple[float, float, float]] = {
    "car": (4.6, 1.85, 1.5),
    "suv": (4.9, 1.95, 1.75),
    "van": (5.6, 2.0, 2.4),
    "truck": (12.0, 2.5, 3.8),
}
"""Length, width, height (metres) of each vehicle style."""

VEHICLE_COLORS: tuple[tuple[int, int, int], ...] = (
    (30, 30, 30),
    (200, 200, 200),
    (235, 235, 235),
    (40, 40, 150),
    (140, 70, 30),
    (110, 110, 110),
    (40, 90, 40),
    (20, 40, 90),
)


@dataclass(frozen=True)
class TrafficRecipe:
    """How the ego vehicle drives and what traffic surrounds it.

    Attributes:
        speed_mps: Mean ego speed, m/s (clipped to 5-35 m/s).
        speed_variation_mps: Amplitude of the slow speed changes, m/s.
        ego_lanes: Lanes (0 = leftmost) the ego vehicle may use.
        lane_change_every_m: Mean distance between lane changes, metres (0 = never).
        wander_m: Amplitude of the lateral wander inside the lane, metres.
        leader: Put a preceding vehicle in the ego lane.
        leader_gap_m: Mean gap to the preceding vehicle, metres.
        cut_in: A vehicle from an adjacent lane cuts in during the drive.
        others_per_km: Vehicles per km in the other lanes.
        oncoming_speed_mps: Speed of oncoming vehicles, m/s.
        stop_every_s: Mean driving time between stops at lights, seconds (0: never stop).
        stop_s: Range of the standstill durations, seconds.
        crawl_s: Creeping time before each stop (queue moving up), seconds.
        crawl_mps: Creeping speed, m/s.
    """

    speed_mps: float = 27.0
    speed_variation_mps: float = 3.0
    ego_lanes: tuple[int, ...] = (1,)
    lane_change_every_m: float = 0.0
    wander_m: float = 0.2
    leader: bool = True
    leader_gap_m: float = 40.0
    cut_in: bool = False
    others_per_km: float = 12.0
    oncoming_speed_mps: float = 12.0
    stop_every_s: float = 0.0
    stop_s: tuple[float, float] = (20.0, 90.0)
    crawl_s: float = 6.0
    crawl_mps: float = 1.0


@dataclass(frozen=True)
class VehicleTrack:
    """One other vehicle over the motion time grid.

    Attributes:
        style: Key of :data:`VEHICLE_SHAPES`.
        color_bgr: Body colour.
        s_m: Arc length of its centre at each time step, metres.
        l_m: Lateral offset of its centre at each time step, metres.
        oncoming: Drives against the ego direction.
    """

    style: str
    color_bgr: tuple[int, int, int]
    s_m: FloatArray
    l_m: FloatArray
    oncoming: bool = False


@dataclass(frozen=True)
class EgoPath:
    """The ego path over the road grid and the ego state over the time grid.

    Attributes:
        l_m: Lateral offset of the ego origin on the road grid, metres.
        lane_plan_m: Offset of the planned lane centre (no wander) on the road grid, metres.
        x_m: East position of the path on the road grid, metres.
        y_m: North position of the path on the road grid, metres.
        heading_rad: Path heading on the road grid, radians (unwrapped).
        curvature: Path curvature on the road grid, 1/m, left positive.
        sigma_m: Path length on the road grid, metres.
        t_s: Time grid, seconds.
        speed_mps: Speed on the time grid, m/s.
        s_m: Reference arc length of the ego position on the time grid, metres.
    """

    l_m: FloatArray
    lane_plan_m: FloatArray
    x_m: FloatArray
    y_m: FloatArray
    heading_rad: FloatArray
    curvature: FloatArray
    sigma_m: FloatArray
    t_s: FloatArray
    speed_mps: FloatArray
    s_m: FloatArray


def _smootherstep(u: FloatArray) -> FloatArray:
    u = np.clip(u, 0.0, 1.0)
    out: FloatArray = u * u * u * (u * (6.0 * u - 15.0) + 10.0)
    return out


def _slow_noise(
    rng: np.random.Generator, x: FloatArray, periods: tuple[float, float], n: int = 3
) -> FloatArray:
    """Sum of ``n`` sines with random periods in ``periods`` and phases, unit peak amplitude."""
    out = np.zeros_like(x)
    for _ in range(n):
        period = float(rng.uniform(*periods))
        phase = float(rng.uniform(0.0, 2 * np.pi))
        out += np.sin(2 * np.pi * x / period + phase)
    return out / n


def speed_profile(rng: np.random.Generator, t_s: FloatArray, recipe: TrafficRecipe) -> FloatArray:
    """Return a smooth speed profile over ``t_s`` (m/s, within 5-35 m/s)."""
    mean = float(np.clip(recipe.speed_mps, MIN_SPEED_MPS, MAX_SPEED_MPS))
    v = mean + recipe.speed_variation_mps * _slow_noise(rng, t_s, (20.0, 60.0))
    v = np.clip(v, MIN_SPEED_MPS, MAX_SPEED_MPS)
    if recipe.stop_every_s > 0:
        v = np.minimum(v, _stop_envelope(rng, t_s, recipe))
    return v


DECEL_MPS2 = 2.0
"""Braking towards a stop or the crawl, m/s^2."""
ACCEL_MPS2 = 1.5
"""Pulling away after a stop, m/s^2."""


def _stop_envelope(rng: np.random.Generator, t_s: FloatArray, recipe: TrafficRecipe) -> FloatArray:
    """Return the speed limit of stop-and-go traffic: cruise, crawl, stand, pull away (m/s)."""
    cruise = float(MAX_SPEED_MPS)
    target = np.full(t_s.shape, cruise)
    t_end = float(t_s[-1]) if t_s.size else 0.0
    t = float(rng.uniform(0.5, 1.0)) * recipe.stop_every_s
    while t < t_end:
        crawl_start = t
        stand_start = crawl_start + recipe.crawl_s
        stand_end = stand_start + float(rng.uniform(*recipe.stop_s))
        target[(t_s >= crawl_start) & (t_s < stand_start)] = recipe.crawl_mps
        target[(t_s >= stand_start) & (t_s < stand_end)] = 0.0
        t = stand_end + float(rng.uniform(0.5, 1.5)) * recipe.stop_every_s
    # Rate-limit the target both ways: brake ahead of each drop, accelerate after each rise.
    dt = float(t_s[1] - t_s[0]) if t_s.size > 1 else 1.0
    env = target.copy()
    for i in range(env.size - 2, -1, -1):  # braking: reach the lower speed in time
        env[i] = min(env[i], env[i + 1] + DECEL_MPS2 * dt)
    for i in range(1, env.size):  # pulling away
        env[i] = min(env[i], env[i - 1] + ACCEL_MPS2 * dt)
    return env


def _lane_plan(
    road: Road, rng: np.random.Generator, recipe: TrafficRecipe
) -> tuple[FloatArray, int]:
    """Return the planned lane-centre offset over the road grid and the starting lane."""
    s = road.s_m
    lanes = sorted(recipe.ego_lanes)
    lane = int(lanes[int(rng.integers(len(lanes)))])
    plan = np.full_like(s, road.lane_center_m(lane))
    start = lane
    if recipe.lane_change_every_m > 0 and len(lanes) > 1:
        s_c = float(rng.uniform(0.4, 1.0)) * recipe.lane_change_every_m
        while s_c < road.length_m - 150.0:
            options = [k for k in lanes if abs(k - lane) == 1]
            if not options:
                break
            new = int(options[int(rng.integers(len(options)))])
            length = float(rng.uniform(80.0, 130.0))
            delta = road.lane_center_m(new) - road.lane_center_m(lane)
            plan += delta * _smootherstep((s - s_c) / length)
            lane = new
            s_c += length + float(rng.exponential(recipe.lane_change_every_m)) + 60.0
    return plan, start


def ego_path(
    road: Road, rng: np.random.Generator, recipe: TrafficRecipe, duration_s: float
) -> EgoPath:
    """Plan the ego path along ``road`` and drive it for ``duration_s`` seconds."""
    s = road.s_m
    plan, _ = _lane_plan(road, rng, recipe)
    wander = recipe.wander_m * _slow_noise(rng, s, (120.0, 400.0))
    lat = plan + wander
    smp = road.sample(s)
    x = smp["x"] - lat * np.sin(smp["heading"])
    y = smp["y"] + lat * np.cos(smp["heading"])
    dx, dy = np.gradient(x), np.gradient(y)
    heading = np.unwrap(np.arctan2(dy, dx))
    dsig = np.hypot(np.diff(x), np.diff(y))
    sigma = np.concatenate([[0.0], np.cumsum(dsig)])
    curvature = np.gradient(heading) / np.maximum(np.hypot(dx, dy), 1e-9)

    n_t = int(np.ceil(duration_s / TIME_STEP_S)) + 1
    t = np.arange(n_t, dtype=np.float64) * TIME_STEP_S
    v = speed_profile(rng, t, recipe)
    travelled = np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * TIME_STEP_S)])
    sigma0 = float(np.interp(20.0, s, sigma))  # start 20 m into the road
    s_t = np.interp(sigma0 + travelled, sigma, s)
    return EgoPath(
        l_m=lat,
        lane_plan_m=plan,
        x_m=x,
        y_m=y,
        heading_rad=heading,
        curvature=curvature,
        sigma_m=sigma,
        t_s=t,
        speed_mps=v,
        s_m=s_t,
    )


@dataclass(frozen=True)
class EgoState:
    """The ego state at one instant.

    Attributes:
        t_s: Time since the start, seconds.
        pose: World pose.
        lateral_m: Lateral offset from the reference line, metres.
        speed_mps: Speed, m/s.
        curvature: Path curvature, 1/m (left positive).
        yaw_rate_rps: Yaw rate, rad/s (left positive).
    """

    t_s: float
    pose: EgoPose
    lateral_m: float
    speed_mps: float
    curvature: float
    yaw_rate_rps: float


def ego_state(road: Road, path: EgoPath, t_s: float) -> EgoState:
    """Interpolate the ego state at time ``t_s`` (seconds since the start)."""
    s = float(np.interp(t_s, path.t_s, path.s_m))
    v = float(np.interp(t_s, path.t_s, path.speed_mps))
    k = float(np.interp(s, road.s_m, path.curvature))
    pose = EgoPose(
        s_m=s,
        x_m=float(np.interp(s, road.s_m, path.x_m)),
        y_m=float(np.interp(s, road.s_m, path.y_m)),
        z_m=float(np.interp(s, road.s_m, road.z_m)),
        heading_rad=float(np.interp(s, road.s_m, path.heading_rad)),
        pitch_rad=float(np.arctan(np.interp(s, road.s_m, road.grade))),
    )
    lateral = float(np.interp(s, road.s_m, path.l_m))
    return EgoState(t_s, pose, lateral, v, k, k * v)


def _vehicle_style(rng: np.random.Generator) -> tuple[str, tuple[int, int, int]]:
    styles = ("car", "car", "car", "suv", "suv", "van", "truck")
    style = styles[int(rng.integers(len(styles)))]
    color = VEHICLE_COLORS[int(rng.integers(len(VEHICLE_COLORS)))]
    return style, color


def traffic(
    road: Road, path: EgoPath, rng: np.random.Generator, recipe: TrafficRecipe
) -> tuple[VehicleTrack, ...]:
    """Generate the other vehicles: leader, optional cut-in, vehicles in other lanes."""
    t = path.t_s
    s_ego = path.s_m
    plan_t = np.interp(s_ego, road.s_m, path.lane_plan_m)
    tracks: list[VehicleTrack] = []
    duration = float(t[-1])
    cut_gap: FloatArray | None = None
    if recipe.cut_in:
        t_c = float(rng.uniform(0.3, 0.5)) * duration
        n_lanes = len(road.lane_widths_m)
        plan_c = float(np.interp(t_c, t, plan_t))
        ego_lane = int(np.argmin([abs(road.lane_center_m(k) - plan_c) for k in range(n_lanes)]))
        usable = n_lanes - (1 if road.recipe.merge else 0)
        side = ego_lane + 1 if ego_lane + 1 < usable else ego_lane - 1
        u = _smootherstep((t - t_c) / 3.0)
        lat = road.lane_center_m(side) + (plan_t - road.lane_center_m(side)) * u
        cut_gap = 26.0 - 9.0 * u + 0.5 * np.clip(t - t_c - 3.0, 0.0, None)
        style, color = _vehicle_style(rng)
        style = "car" if style == "truck" else style
        tracks.append(VehicleTrack(style, color, s_ego + cut_gap, lat))
    if recipe.leader:
        gap = recipe.leader_gap_m + 0.45 * recipe.leader_gap_m * _slow_noise(rng, t, (15.0, 40.0))
        gap = np.clip(gap, 12.0, 90.0)
        if cut_gap is not None:
            gap = np.maximum(gap, cut_gap + 18.0)
        style, color = _vehicle_style(rng)
        lat = plan_t + 0.15 * _slow_noise(rng, t, (8.0, 20.0))
        tracks.append(VehicleTrack(style, color, s_ego + gap, lat))
    n_lanes = len(road.lane_widths_m)
    length = road.length_m
    n_other = int(rng.poisson(recipe.others_per_km * length / 1000.0))
    ego_lanes = set(recipe.ego_lanes)
    v_mean = float(np.mean(path.speed_mps))
    for _ in range(n_other):
        lane = int(rng.integers(n_lanes))
        oncoming = lane < road.recipe.oncoming_lanes
        if lane in ego_lanes and len(ego_lanes) == 1:
            continue
        if road.recipe.merge and lane == n_lanes - 1:
            continue
        if oncoming:
            s_track = float(rng.uniform(0.0, length)) - recipe.oncoming_speed_mps * t
        else:
            speed = v_mean + float(rng.uniform(-4.0, 4.0))
            s_track = float(rng.uniform(-100.0, length * 0.6)) + speed * t
        style, color = _vehicle_style(rng)
        lat = np.full_like(t, road.lane_center_m(lane)) + float(rng.uniform(-0.25, 0.25))
        if _conflicts(s_track, lat, s_ego, plan_t, tracks):
            continue
        tracks.append(VehicleTrack(style, color, s_track, lat, oncoming))
    return tuple(tracks)


def _conflicts(
    s_m: FloatArray,
    l_m: FloatArray,
    s_ego: FloatArray,
    l_ego: FloatArray,
    others: list[VehicleTrack],
) -> bool:
    """Return True if a track would drive through the ego vehicle or an earlier track."""
    for s2, l2 in [(s_ego, l_ego), *((o.s_m, o.l_m) for o in others)]:
        if np.any((np.abs(s_m - s2) < 16.0) & (np.abs(l_m - l2) < 2.6)):
            return True
    return False
