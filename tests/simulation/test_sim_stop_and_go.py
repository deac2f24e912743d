"""The stop_and_go scenario: stops of 20-90 s after a crawl, and what the sensors report then."""

from __future__ import annotations

import numpy as np

from superlane_tools.can import decode_frames, load_dbc
from superlane_tools.geo import fix_speed, geodetic_to_enu
from superlane_tools.simulation.scenarios import SCENARIOS
from superlane_tools.simulation.sensors import (
    VEHICLE_DBC,
    RtkParams,
    dbc_path,
    gnss_fixes,
    rtk_fixes,
    vehicle_can,
)
from superlane_tools.simulation.world import build_world


def test_stop_and_go_stands_20_to_90_s_after_a_crawl() -> None:
    world = build_world(SCENARIOS["stop_and_go"], 2, 80.0)
    t, v = world.path.t_s, world.path.speed_mps
    standing = v < 0.01
    assert standing.any()
    edges = np.flatnonzero(np.diff(standing.astype(int)))
    first = t[edges[0] + 1]
    last = t[edges[1]] if edges.size > 1 else t[-1]
    assert last - first >= 20.0 or last == t[-1]
    crawl = (v > 0.5) & (v < 1.5)
    assert crawl.sum() * (t[1] - t[0]) >= 3.0  # the queue creeps before the stop
    assert v.max() > 10.0


def test_sensors_while_standing_give_jitter_not_motion() -> None:
    world = build_world(SCENARIOS["stop_and_go"], 2, 80.0)
    rng = np.random.default_rng(0)
    fixes = rtk_fixes(world, RtkParams(), 0, rng)
    arr = np.array([(f.log_time_ns, f.lat_deg, f.lon_deg, f.alt_m) for f in fixes])
    enu = geodetic_to_enu(arr[:, 1], arr[:, 2], arr[:, 3])
    t_ns = arr[:, 0].astype(np.int64)
    true_v = np.interp(t_ns / 1e9, world.path.t_s, world.path.speed_mps)
    est = fix_speed(t_ns, enu.east_m, enu.north_m)
    standing = true_v < 0.01
    assert standing.sum() > 100
    assert np.nanmax(est[standing]) < 0.2  # cm jitter reads as < 0.2 m/s over 1 s
    frames = vehicle_can(world, 0, rng)
    db = load_dbc(dbc_path(VEHICLE_DBC)).database
    table = decode_frames(
        db, [f.can_id for f in frames], [f.data for f in frames], [f.log_time_ns for f in frames]
    )
    speed = table[table["signal"] == "VehicleSpeed"]["value"].to_numpy()
    assert (speed < 0.1).sum() > 500  # the CAN speed reads standstill


def test_multipath_jumps_are_flagged_and_kept_out_of_the_truth() -> None:
    from superlane_tools.drive.config import RtkConfig
    from superlane_tools.drive.signals import rtk_truth

    world = build_world(SCENARIOS["highway_curves"], 4, 60.0)
    params = RtkParams(multipath_per_min=4.0)
    fixes = rtk_fixes(world, params, 0, np.random.default_rng(1))
    assert any(f.status == 1 for f in fixes)
    rows = gnss_fixes(fixes)
    t = np.arange(0.0, 60.0, 1 / 15)
    path = world.path
    true_k = np.interp(np.interp(t, path.t_s, path.s_m), world.road.s_m, path.curvature)
    truth = rtk_truth(rows, (t * 1e9).astype(np.int64), RtkConfig())
    assert truth.n_degraded == sum(f.status == 1 for f in fixes)
    k = truth.frame_curvature
    ok = np.isfinite(k)
    assert ok.sum() > 300
    assert np.sqrt(np.mean((k[ok] - true_k[ok]) ** 2)) < 2e-4
