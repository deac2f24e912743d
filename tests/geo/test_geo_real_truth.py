"""Truth that holds on real drives: standstill, plain GNSS, and the yaw-rate reference."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from superlane_tools.can import decode_frames, load_dbc, to_si
from superlane_tools.geo import (
    DEGRADED_NOTE,
    curvature_noise_floor,
    geodetic_to_enu,
    grade_fixes,
    trajectory_curvature,
    yaw_rate_curvature,
)
from superlane_tools.recording.open import open_recording


def _fixes(path: Path, topics: list[str] | None = None):
    rows = []
    with open_recording(path) as rec:
        gnss = [t.topic for t in rec.topics() if t.msgtype.endswith("NavSatFix")]
        for msg in rec.messages(topics=topics or gnss):
            d = msg.data
            rows.append((msg.log_time_ns, d.latitude, d.longitude, d.altitude, d.status.status))
    arr = np.array(rows, dtype=np.float64)
    return arr[:, 0].astype(np.int64), arr[:, 1], arr[:, 2], arr[:, 3], arr[:, 4]


def test_static_rtk_receiver_gives_no_truth(realdata: Path) -> None:
    """The real NMEA log is a static RTK receiver: jitter must not become curvature."""
    t, lat, lon, alt, status = _fixes(realdata / "gnss/nmea.log")
    grades = grade_fixes(lat, lon, alt, status, np.full(t.shape, np.nan))
    assert grades.rtk.sum() > 100
    enu = geodetic_to_enu(lat, lon, alt)
    gated = trajectory_curvature(t, enu.east_m, enu.north_m, grades.good, t)
    assert not gated.valid.any()
    assert np.isnan(gated.s_m).all()
    # The receiver never moved, yet its fixes add up to a phantom path: that is what the
    # speed gate and the decimation keep out of the arc length.
    phantom = np.nansum(np.hypot(np.diff(enu.east_m), np.diff(enu.north_m)))
    assert phantom > 0.3


def test_stop_in_a_drive_has_no_truth_sample_while_standing() -> None:
    rng = np.random.default_rng(3)
    t_s = np.arange(0.0, 100.0, 0.1)
    speed = np.where((t_s > 40) & (t_s < 70), 0.0, 15.0)  # 30 s at a light
    s = np.cumsum(speed * 0.1)
    radius = 400.0
    e = radius * np.sin(s / radius) + rng.normal(0, 0.02, s.shape)
    n = radius * (1 - np.cos(s / radius)) + rng.normal(0, 0.02, s.shape)
    t = (t_s * 1e9).astype(np.int64)
    for given in (speed, None):  # CAN speed, or speed from the fixes themselves
        res = trajectory_curvature(t, e, n, np.ones(t.shape, bool), t, speed_mps=given)
        standing = speed < 2.0
        assert not res.valid[standing].any()
        k = res.curvature_per_m[res.valid]
        assert k.size > 300
        assert np.sqrt(np.mean((k - 1 / radius) ** 2)) < 2.5e-4


def test_noise_floor_at_highway_speed() -> None:
    floor = curvature_noise_floor(0.02, 25.0, 10.0)
    assert 1.3e-4 < floor < 2.0e-4


def _comma_dynamics(comma2k19: Path, realdata: Path):
    gyro_t, gyro_z = [], []
    can_ids, can_data, can_t = [], [], []
    with open_recording(comma2k19) as rec:
        for msg in rec.messages(topics=["/imu", "/can0"]):
            if msg.topic == "/imu":
                gyro_t.append(msg.log_time_ns)
                gyro_z.append(msg.data.angular_velocity.z)
            else:
                can_ids.append(int(msg.data.id))
                can_data.append(bytes(msg.data.data)[: int(msg.data.dlc)])
                can_t.append(msg.log_time_ns)
    db = load_dbc(realdata / "dbc/opendbc/toyota_generator__toyota_2017.dbc").database
    table = decode_frames(db, np.array(can_ids), can_data, np.array(can_t, np.int64))
    speed = table[(table["message"] == "SPEED") & (table["signal"] == "SPEED")]
    speed_mps = to_si(speed["value"].to_numpy(), str(speed["unit"].iloc[0]), "speed", "SPEED")
    return (
        np.array(gyro_t, np.int64),
        -np.array(gyro_z),  # the phone's z axis points down: yaw left is -z
        speed["log_time_ns"].to_numpy(np.int64),
        speed_mps,
    )


@pytest.mark.realdata
def test_comma2k19_yaw_rate_reference_matches_fused_trajectory(
    realdata: Path, comma2k19: Path
) -> None:
    import pymap3d

    from superlane_tools.recording.open import open_recording as _open  # noqa: F401

    spec_t = np.load(realdata / "comma2k19/segment/global_pose/frame_times")
    pos = np.load(realdata / "comma2k19/segment/global_pose/frame_positions")
    t_fused = (spec_t * 1e9).round().astype(np.int64)
    lat0, lon0, alt0 = pymap3d.ecef2geodetic(*pos[0])
    e, n, _ = pymap3d.ecef2enu(pos[:, 0], pos[:, 1], pos[:, 2], lat0, lon0, alt0)
    fused = trajectory_curvature(t_fused, e, n, np.ones(t_fused.shape, bool), t_fused)
    yaw_t, yaw, speed_t, speed = _comma_dynamics(comma2k19, realdata)
    assert 10.0 < float(np.median(speed)) < 25.0  # SPEED is in kph in the DBC: converted
    ref = yaw_rate_curvature(yaw_t, yaw, speed_t, speed, t_fused)
    both = ref.valid & fused.valid
    assert both.sum() > 800
    rms = float(np.sqrt(np.mean((ref.curvature_per_m[both] - fused.curvature_per_m[both]) ** 2)))
    assert rms < 1.5e-4, rms
    # Plain u-blox fixes (status 0): used, but the truth is flagged degraded.
    t, lat, lon, alt, status = _fixes(comma2k19, ["/gnss/fix"])
    grades = grade_fixes(lat, lon, alt, status, np.full(t.shape, np.nan))
    assert grades.degraded
    assert not grades.rtk.any()
    assert all(DEGRADED_NOTE in r for r in grades.reasons)
