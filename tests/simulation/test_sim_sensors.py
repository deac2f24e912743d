"""Simulated sensors: CAN decodes with the shipped DBCs, Mobileye signs, RTK curvature."""

from __future__ import annotations

import numpy as np
import pymap3d
import pytest

from superlane_tools.camera.model import CameraModel, Extrinsics, Intrinsics
from superlane_tools.can import load_dbc
from superlane_tools.simulation.groundtruth import lane_truth
from superlane_tools.simulation.scenarios import SCENARIOS
from superlane_tools.simulation.sensors import (
    MOBILEYE_DBC,
    VEHICLE_DBC,
    MobileyeParams,
    RtkParams,
    dbc_path,
    mobileye_can,
    mobileye_to_lane_model,
    rtk_fixes,
    vehicle_can,
)
from superlane_tools.simulation.world import build_world, frame_world

CAMERA = CameraModel(Intrinsics(1280, 720, 1000.0, 1000.0, 639.5, 359.5), Extrinsics(1.5, 0.06))
START = 1_700_000_000_000_000_000


@pytest.fixture(scope="module")
def curvy_world():  # type: ignore[no-untyped-def]
    return build_world(SCENARIOS["highway_curves"], 4, 30.0)


def test_shipped_dbcs_load_cleanly_with_the_project_loader() -> None:
    for name in (VEHICLE_DBC, MOBILEYE_DBC):
        loaded = load_dbc(dbc_path(name))
        assert loaded.repairs == []
    ids = {m.frame_id for m in load_dbc(dbc_path(MOBILEYE_DBC)).database.messages}
    assert ids == {0x766, 0x767, 0x768, 0x769}


def test_vehicle_can_decodes_to_the_true_speed_and_yaw_rate(curvy_world) -> None:  # type: ignore[no-untyped-def]
    db = load_dbc(dbc_path(VEHICLE_DBC)).database
    frames = vehicle_can(curvy_world, START, np.random.default_rng(0))
    speed, yaw, t = [], [], []
    for f in frames:
        sig = db.decode_message(f.can_id, f.data)
        if f.can_id == 0x180:
            speed.append(sig["VehicleSpeed"])
            t.append((f.log_time_ns - START) / 1e9)
        else:
            yaw.append(sig["YawRate"])
    path, road = curvy_world.path, curvy_world.road
    v_true = np.interp(t, path.t_s, path.speed_mps)
    k_true = np.interp(np.interp(t, path.t_s, path.s_m), road.s_m, path.curvature)
    assert len(speed) == 50 * 30 + 1
    assert np.median(np.abs(np.asarray(speed) - v_true)) < 0.1
    assert np.median(np.abs(np.asarray(yaw) - k_true * v_true)) < 0.01


def test_mobileye_frames_decode_to_the_lane_model_with_flipped_signs(curvy_world) -> None:  # type: ignore[no-untyped-def]
    db = load_dbc(dbc_path(MOBILEYE_DBC)).database
    fw = frame_world(curvy_world, 6.0, START, CAMERA, 0)
    truth = lane_truth(fw)
    frames = mobileye_can(truth, START, MobileyeParams(quality=3), np.random.default_rng(1))
    assert [f.can_id for f in frames] == [0x766, 0x767, 0x768, 0x769]
    assert all(f.log_time_ns >= START + 100_000_000 for f in frames)  # 100 ms latency
    a = db.decode_message(0x766, frames[0].data, decode_choices=False)
    b = db.decode_message(0x767, frames[1].data, decode_choices=False)
    a0, a1, a2, _ = mobileye_to_lane_model(
        a["Curve_Parameter_C0"], b["Curve_Parameter_C1"], a["Curve_Parameter_C2"], 0.0
    )
    left = truth.cubic[truth.ego_left]
    assert a0 == pytest.approx(left[0], abs=0.15)
    assert a0 > 0
    assert a1 == pytest.approx(left[1], abs=0.01)
    assert a2 == pytest.approx(left[2], abs=1e-4)
    assert a["Quality"] == 3
    right = db.decode_message(0x768, frames[2].data, decode_choices=False)
    assert right["Curve_Parameter_C0"] > 0  # right line: positive in the Mobileye convention


def _curvature_from_enu(e: np.ndarray, n: np.ndarray, window_m: float = 30.0) -> np.ndarray:
    """Curvature (1/m) from ENU points by local quadratic fits over +-window_m/2 of arc length."""
    s = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(e), np.diff(n)))])
    out = np.full(len(s), np.nan)
    for i in range(len(s)):
        sel = np.abs(s - s[i]) <= window_m / 2
        if sel.sum() < 7:
            continue
        pe = np.polyfit(s[sel] - s[i], e[sel], 2)
        pn = np.polyfit(s[sel] - s[i], n[sel], 2)
        de, dn, dde, ddn = pe[1], pn[1], 2 * pe[0], 2 * pn[0]
        out[i] = (de * ddn - dn * dde) / (de * de + dn * dn) ** 1.5
    return out


def test_rtk_trajectory_curvature_matches_the_path(curvy_world) -> None:  # type: ignore[no-untyped-def]
    params = RtkParams()
    fixes = rtk_fixes(curvy_world, params, START, np.random.default_rng(2))
    assert len(fixes) == 10 * 30 + 1
    assert all(f.status == 2 for f in fixes)
    lat = np.array([f.lat_deg for f in fixes])
    lon = np.array([f.lon_deg for f in fixes])
    alt = np.array([f.alt_m for f in fixes])
    e, n, _ = pymap3d.geodetic2enu(
        lat, lon, alt, params.origin_lat_deg, params.origin_lon_deg, params.origin_alt_m
    )
    k_rtk = _curvature_from_enu(np.asarray(e), np.asarray(n))
    t = np.array([(f.log_time_ns - START) / 1e9 for f in fixes])
    path, road = curvy_world.path, curvy_world.road
    k_true = np.interp(np.interp(t, path.t_s, path.s_m), road.s_m, path.curvature)
    ok = np.isfinite(k_rtk)
    assert ok.sum() > 250
    assert np.max(np.abs(k_true)) > 3e-3  # the drive really curves
    assert np.median(np.abs(k_rtk[ok] - k_true[ok])) < 2.5e-4
    # and the positions themselves: centimetres
    e_true = np.interp(np.interp(t, path.t_s, path.s_m), road.s_m, path.x_m)
    assert np.std(np.asarray(e) - e_true) < 0.03


def test_degraded_rtk_reports_its_status_and_drops_out(curvy_world) -> None:  # type: ignore[no-untyped-def]
    params = RtkParams(mode="standalone", dropouts_per_min=6.0, rate_hz=20.0)
    fixes = rtk_fixes(curvy_world, params, START, np.random.default_rng(3))
    assert all(f.status == 0 for f in fixes)
    assert len(fixes) < 20 * 30 + 1
    assert fixes[0].covariance_enu_m2[0] > 1.0  # metres of uncertainty
