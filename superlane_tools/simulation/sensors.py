"""Simulated sensors: vehicle CAN, Mobileye-style lane CAN, RTK fixes, camera info and extrinsics.

All functions are pure: they take the world (or per-frame truth) and a seeded generator and
return timed payloads; the drive writer (``drive.py``) serialises them with the recording layer.
CAN payloads are encoded with cantools from the shipped DBCs (``superlane_tools/data/dbc``).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache
from importlib import resources
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from superlane_tools.reporting.gnss_fixes import GnssFixes
from superlane_tools.simulation.errors import ScenarioError
from superlane_tools.simulation.groundtruth import LaneTruth
from superlane_tools.simulation.world import World

FloatArray = NDArray[np.float64]

VEHICLE_DBC = "slt_vehicle.dbc"
VEHICLE_KPH_DBC = "slt_vehicle_kph.dbc"
"""The same vehicle bus with the speed in km/h (0.01 km/h per bit), as many vehicles send it."""
MOBILEYE_DBC = "slt_mobileye_lanes.dbc"
ANTENNA_HEIGHT_M = 1.5
"""GNSS antenna height above the vehicle origin (road surface), metres."""

# Mobileye Lane_Type values
_LANE_TYPE = {"dashed": 0, "solid": 1, "double": 4}
_LANE_TYPE_INVALID = 6


class CanPayload(NamedTuple):
    """One CAN frame to write: time (ns since the epoch), arbitration id, data bytes."""

    log_time_ns: int
    can_id: int
    data: bytes


class FixSample(NamedTuple):
    """One GNSS fix: time (ns), WGS84 position, ROS NavSatStatus, ENU covariance (m^2)."""

    log_time_ns: int
    lat_deg: float
    lon_deg: float
    alt_m: float
    status: int
    covariance_enu_m2: tuple[float, ...]


def dbc_path(name: str) -> str:
    """Return the filesystem path of a shipped DBC file (``slt_vehicle.dbc``...)."""
    return str(resources.files("superlane_tools").joinpath("data", "dbc", name))


@cache
def load_shipped_dbc(name: str) -> Any:
    """Load a shipped DBC with cantools (cached)."""
    import cantools

    return cantools.database.load_file(dbc_path(name))


@dataclass(frozen=True)
class RtkParams:
    """GNSS receiver simulation.

    Attributes:
        rate_hz: Fix rate, Hz (10-20).
        mode: ``fixed`` (RTK fixed, cm noise), ``float`` (RTK float, ~0.2 m) or
            ``standalone`` (single point, metres of slowly wandering error).
        dropouts_per_min: Mean number of outages per minute (each 1-4 s without fixes).
        multipath_per_min: Mean number of multipath episodes per minute: for 2-8 s the fixes
            jump 0.3-1.5 m sideways and the receiver reports RTK float (status 1) with a
            covariance that says so.
        origin_lat_deg: Latitude of the world origin, degrees.
        origin_lon_deg: Longitude of the world origin, degrees.
        origin_alt_m: Ellipsoidal height of the world origin, metres.
    """

    rate_hz: float = 10.0
    mode: str = "fixed"
    dropouts_per_min: float = 0.0
    multipath_per_min: float = 0.0
    origin_lat_deg: float = 48.137154
    origin_lon_deg: float = 11.576124
    origin_alt_m: float = 520.0

    def validate(self) -> None:
        """Raise :class:`ScenarioError` for an impossible setting."""
        if not 1.0 <= self.rate_hz <= 50.0:
            raise ScenarioError(f"RTK rate must be 1-50 Hz, got {self.rate_hz}")
        if self.mode not in _RTK_MODES:
            raise ScenarioError(f"RTK mode must be one of {', '.join(_RTK_MODES)}")


# mode -> (NavSatStatus.status, white sigma horizontal m, vertical m, wander sigma m, tau s)
_RTK_MODES: dict[str, tuple[int, float, float, float, float]] = {
    "fixed": (2, 0.01, 0.02, 0.003, 60.0),
    "float": (1, 0.05, 0.10, 0.20, 30.0),
    "standalone": (0, 0.30, 0.60, 1.50, 60.0),
}


def _ar1(rng: np.random.Generator, n: int, dt_s: float, sigma: float, tau_s: float) -> FloatArray:
    """Return ``n`` samples of a first-order Gauss-Markov process (stationary ``sigma``)."""
    phi = float(np.exp(-dt_s / tau_s))
    drive = rng.normal(0.0, sigma * np.sqrt(1.0 - phi * phi), n)
    out = np.empty(n)
    state = float(rng.normal(0.0, sigma))
    for i in range(n):
        state = phi * state + drive[i]
        out[i] = state
    return out


def gnss_fixes(fixes: list[FixSample], topic: str = "/gnss/fix") -> GnssFixes:
    """Return fixes as a GNSS sink collects them (``reprocess``'s truth takes these)."""
    return GnssFixes.from_rows(
        {
            "topic": topic,
            "log_time_ns": f.log_time_ns,
            "latitude_deg": f.lat_deg,
            "longitude_deg": f.lon_deg,
            "altitude_m": f.alt_m,
            "fix_status": f.status,
            "covariance_m2": list(f.covariance_enu_m2),
        }
        for f in fixes
    )


def rtk_fixes(
    world: World, params: RtkParams, start_ns: int, rng: np.random.Generator
) -> list[FixSample]:
    """Simulate NavSatFix samples of the ego antenna over the drive.

    The true antenna position is the ego origin (world ENU, metres) raised by
    :data:`ANTENNA_HEIGHT_M`, converted to WGS84 with ``pymap3d.enu2geodetic`` from the
    configured origin.
    """
    import pymap3d

    params.validate()
    status, s_h, s_v, wander, tau = _RTK_MODES[params.mode]
    dt = 1.0 / params.rate_hz
    t = np.arange(0.0, world.duration_s + 1e-9, dt)
    road, path = world.road, world.path
    s = np.interp(t, path.t_s, path.s_m)
    east = np.interp(s, road.s_m, path.x_m)
    north = np.interp(s, road.s_m, path.y_m)
    up = np.interp(s, road.s_m, road.z_m) + ANTENNA_HEIGHT_M
    n = len(t)
    east = east + rng.normal(0.0, s_h, n) + _ar1(rng, n, dt, wander, tau)
    north = north + rng.normal(0.0, s_h, n) + _ar1(rng, n, dt, wander, tau)
    up = up + rng.normal(0.0, s_v, n) + _ar1(rng, n, dt, 1.5 * wander, tau)
    keep = np.ones(n, dtype=bool)
    n_out = int(rng.poisson(params.dropouts_per_min * world.duration_s / 60.0))
    for _ in range(n_out):
        t0 = float(rng.uniform(0.0, world.duration_s))
        keep &= ~((t >= t0) & (t < t0 + float(rng.uniform(1.0, 4.0))))
    jumped = np.zeros(n, dtype=bool)
    if params.multipath_per_min > 0:
        # Drawn from their own generator: the other draws (and drives) stay the same.
        mp_rng = np.random.default_rng(rng.integers(0, 2**31))
        for _ in range(int(mp_rng.poisson(params.multipath_per_min * world.duration_s / 60))):
            t0 = float(mp_rng.uniform(0.0, world.duration_s))
            span = (t >= t0) & (t < t0 + float(mp_rng.uniform(2.0, 8.0)))
            angle = float(mp_rng.uniform(0.0, 2 * np.pi))
            size = float(mp_rng.uniform(0.3, 1.5))
            east[span] += size * np.cos(angle)
            north[span] += size * np.sin(angle)
            jumped |= span
    lat, lon, alt = pymap3d.enu2geodetic(
        east, north, up, params.origin_lat_deg, params.origin_lon_deg, params.origin_alt_m
    )
    var_h = s_h * s_h + wander * wander
    var_v = s_v * s_v + 2.25 * wander * wander
    cov = (var_h, 0.0, 0.0, 0.0, var_h, 0.0, 0.0, 0.0, var_v)
    cov_jump = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 2.0)
    return [
        FixSample(
            start_ns + round(float(t[i]) * 1e9),
            float(lat[i]),
            float(lon[i]),
            float(alt[i]),
            min(status, 1) if jumped[i] else status,
            cov_jump if jumped[i] else cov,
        )
        for i in range(n)
        if keep[i]
    ]


@dataclass(frozen=True)
class VehicleOptions:
    """How the simulated vehicle reports itself.

    Attributes:
        speed_kph: Send the speed in km/h (:data:`VEHICLE_KPH_DBC`) instead of m/s.
        imu: Also write a ``sensor_msgs/Imu`` topic (gyro z = yaw rate, with its own bias).
        second_bus: Put the Mobileye lanes on a second CAN bus, together with a camera
            heartbeat whose id (0x180) collides with the vehicle bus's speed message.
        mobileye_latency_s: Delay of the Mobileye lane messages after their camera frame,
            seconds (0-1).
    """

    speed_kph: bool = False
    imu: bool = False
    second_bus: bool = False
    mobileye_latency_s: float = 0.1

    def __post_init__(self) -> None:
        if not 0.0 <= self.mobileye_latency_s <= 1.0:
            raise ScenarioError(f"Mobileye latency must be 0-1 s, got {self.mobileye_latency_s} s")


HEARTBEAT_ID = 0x180
"""Id of the second bus's camera heartbeat: the same id as the vehicle bus's speed."""


def heartbeat_can(world: World, start_ns: int, rate_hz: float = 10.0) -> list[CanPayload]:
    """A camera heartbeat on the second bus (id 0x180, a counter and status bytes)."""
    t = np.arange(0.0, world.duration_s + 1e-9, 1.0 / rate_hz)
    return [
        CanPayload(
            start_ns + round(float(ti) * 1e9) + 500,
            HEARTBEAT_ID,
            bytes([0xA5, i % 256, 3, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF]),
        )
        for i, ti in enumerate(t)
    ]


def imu_gyro(
    world: World, start_ns: int, rng: np.random.Generator, rate_hz: float = 100.0
) -> list[tuple[int, tuple[float, float, float]]]:
    """Simulate an IMU's gyro (rad/s, x forward, y left, z up) with a constant bias and noise."""
    t = np.arange(0.0, world.duration_s + 1e-9, 1.0 / rate_hz)
    path, road = world.path, world.road
    v = np.interp(t, path.t_s, path.speed_mps)
    k = np.interp(np.interp(t, path.t_s, path.s_m), road.s_m, path.curvature)
    bias = rng.normal(0.0, 0.003, 3)
    noise = rng.normal(0.0, 0.002, (len(t), 3))
    gyro = noise + bias
    gyro[:, 2] += k * v
    return [
        (start_ns + round(float(ti) * 1e9) + 2000, (float(g[0]), float(g[1]), float(g[2])))
        for ti, g in zip(t, gyro, strict=True)
    ]


def vehicle_can(
    world: World,
    start_ns: int,
    rng: np.random.Generator,
    rate_hz: float = 50.0,
    speed_kph: bool = False,
) -> list[CanPayload]:
    """Encode speed (0x180) and yaw rate (0x181) at ``rate_hz`` with sensor noise and bias.

    With ``speed_kph`` the speed is sent in km/h (:data:`VEHICLE_KPH_DBC`); the random draws
    are the same either way, so the two drives differ only in the speed's unit.
    """
    db = load_shipped_dbc(VEHICLE_KPH_DBC if speed_kph else VEHICLE_DBC)
    speed_msg = db.get_message_by_name("VehicleSpeed")
    yaw_msg = db.get_message_by_name("YawRate")
    dt = 1.0 / rate_hz
    t = np.arange(0.0, world.duration_s + 1e-9, dt)
    path, road = world.path, world.road
    v = np.interp(t, path.t_s, path.speed_mps)
    s = np.interp(t, path.t_s, path.s_m)
    k = np.interp(s, road.s_m, path.curvature)
    accel = np.gradient(v, dt)
    yaw_bias = float(rng.normal(0.0, 0.002))
    v_meas = np.clip(v * (1.0 + 0.002) + rng.normal(0.0, 0.02, len(t)), 0.0, 655.0)
    yaw_meas = k * v + yaw_bias + rng.normal(0.0, 0.003, len(t))
    lat_acc = k * v * v + rng.normal(0.0, 0.05, len(t))
    out: list[CanPayload] = []
    for i, ti in enumerate(t):
        t_ns = start_ns + round(float(ti) * 1e9)
        counter = i % 16
        out.append(
            CanPayload(
                t_ns,
                speed_msg.frame_id,
                speed_msg.encode(
                    {
                        "VehicleSpeed": round(float(v_meas[i]) * (3.6 if speed_kph else 1.0), 2),
                        "SpeedValid": 1,
                        "LongitudinalAccel": round(float(np.clip(accel[i], -32.0, 32.0)), 3),
                        "Counter": counter,
                    }
                ),
            )
        )
        out.append(
            CanPayload(
                t_ns + 1000,  # 1 us later: a deterministic order on the bus
                yaw_msg.frame_id,
                yaw_msg.encode(
                    {
                        "YawRate": round(float(np.clip(yaw_meas[i], -3.2, 3.2)), 4),
                        "YawRateValid": 1,
                        "LateralAccel": round(float(np.clip(lat_acc[i], -32.0, 32.0)), 3),
                        "Counter": counter,
                    }
                ),
            )
        )
    return out


@dataclass(frozen=True)
class MobileyeParams:
    """Mobileye-style lane sensor simulation.

    Attributes:
        latency_s: Delay between the camera frame and the CAN output, seconds.
        quality: Nominal quality 0-3 (scenario dependent; bad weather and faded lines lower).
        max_view_m: Longest reported view range, metres.
    """

    latency_s: float = 0.1
    quality: int = 3
    max_view_m: float = 90.0


# quality -> (noise scale, probability of a dropped (quality 0) frame, view-range scale)
_QUALITY = {3: (1.0, 0.0, 1.0), 2: (1.6, 0.03, 0.8), 1: (3.0, 0.15, 0.55), 0: (6.0, 0.5, 0.3)}


def mobileye_can(
    truth: LaneTruth, frame_ns: int, params: MobileyeParams, rng: np.random.Generator
) -> list[CanPayload]:
    """Encode the ego lane's left/right lines of one frame as 0x766-0x769 frames.

    Coefficients are converted to the Mobileye sign convention (y right positive: every
    coefficient negated, see ``slt_mobileye_lanes.dbc``) and written ``latency_s`` after the
    frame time.
    """
    db = load_shipped_dbc(MOBILEYE_DBC)
    t_ns = frame_ns + round(params.latency_s * 1e9)
    scale, p_drop, view_scale = _QUALITY[int(np.clip(params.quality, 0, 3))]
    out: list[CanPayload] = []
    for side, pos in (("Left", truth.ego_left), ("Right", truth.ego_right)):
        msg_a = db.get_message_by_name(f"{side}_Lane_A")
        msg_b = db.get_message_by_name(f"{side}_Lane_B")
        noise = rng.normal(0.0, 1.0, 5)
        dropped = rng.random() < p_drop
        if pos < 0 or dropped:
            c = np.zeros(4)
            quality, lane_type, width, view = 0, _LANE_TYPE_INVALID, 0.0, 0.0
        else:
            c = truth.cubic[pos].copy()
            c += scale * noise[:4] * np.array([0.03, 0.002, 2e-5, 2e-7])
            quality = int(params.quality)
            lane_type = _LANE_TYPE.get(truth.styles[pos], 2)
            width = truth.widths_m[pos]
            view = min(truth.view_range_m[pos], params.max_view_m) * view_scale
            view = max(0.0, view * (1.0 + 0.05 * float(noise[4])))
        me = -c  # Mobileye: y right positive
        data_a = msg_a.encode(
            {
                "Lane_Type": lane_type,
                "Quality": quality,
                "Model_Degree": 3,
                "Curve_Parameter_C0": float(np.clip(me[0], -127.9, 127.9)),
                "Curve_Parameter_C2": float(np.clip(me[2], -0.0319, 0.0319)),
                "Curve_Parameter_C3": float(np.clip(me[3], -0.000122, 0.000122)),
                f"Width_{side}_Marking": round(float(width), 2),
            }
        )
        data_b = msg_b.encode(
            {
                "Curve_Parameter_C1": float(np.clip(me[1], -31.9, 31.9)),
                "View_Range": float(np.clip(view, 0.0, 127.9)),
                "View_Range_Available": int(view > 0),
            }
        )
        out.append(CanPayload(t_ns, msg_a.frame_id, data_a))
        out.append(CanPayload(t_ns + 1000, msg_b.frame_id, data_b))
    return out


def mobileye_to_lane_model(c0: float, c1: float, c2: float, c3: float) -> tuple[float, ...]:
    """Convert Mobileye ``C0..C3`` (y right positive) to this package's ``a0..a3`` (left positive).

    ``C2`` is half the curvature, so the lane curvature (1/m, left positive) is ``2 * a2``.
    """
    return (-c0, -c1, -c2, -c3)
