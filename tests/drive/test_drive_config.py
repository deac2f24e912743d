"""Unit tests of the reprocess config, Mobileye conversion and RTK flagging."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from superlane_tools.camera.metadata import camera_quaternion_xyzw, extrinsics_from_tf
from superlane_tools.camera.profiles import load_camera
from superlane_tools.can import mobileye_table
from superlane_tools.drive.config import ReprocessConfig, RtkConfig, load_config
from superlane_tools.drive.signals import rtk_truth
from superlane_tools.errors import ConfigError
from superlane_tools.reporting.gnss_fixes import GnssFixes


def test_toml_and_yaml_load_the_same(tmp_path: Path) -> None:
    toml = tmp_path / "c.toml"
    toml.write_text(
        'camera = "sim_default"\n[kpi]\nwindow_s = 10\n[fit]\nkappa = 1.5\n', encoding="utf-8"
    )
    yml = tmp_path / "c.yaml"
    yml.write_text(
        "camera: sim_default\nkpi: {window_s: 10}\nfit: {kappa: 1.5}\n", encoding="utf-8"
    )
    a, b = load_config(toml), load_config(yml)
    assert a == b
    assert a.kpi.window_s == 10.0
    assert a.fit["kappa"] == 1.5


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("[fit]\nkappa_x = 1\n", "unknown fit parameters"),
        ("[fit]\nvertical_curvature_bound = 0.02\n", "vertical_curvature_bound"),
        ("[kpi]\nwindow_s = 'x'\n", "must be a number"),
        ("[segmentation]\nbackend = 'oracle'\n", "oracle_labels"),
        ("nonsense = 1\n", "unknown config keys"),
    ],
)
def test_invalid_configs(tmp_path: Path, text: str, message: str) -> None:
    path = tmp_path / "c.toml"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(ConfigError, match=message):
        load_config(path)


def test_vertical_curvature_is_off_by_default_and_configurable(tmp_path: Path) -> None:
    from superlane_tools.lanes import FitParams

    assert not FitParams.from_dict(dict(ReprocessConfig().fit)).vertical
    path = tmp_path / "c.toml"
    path.write_text("[fit]\nvertical_curvature_bound = 5e-4\n", encoding="utf-8")
    fit = FitParams.from_dict(dict(load_config(path).fit))
    assert fit.vertical_curvature_bound == 5e-4
    assert fit.max_range_m == 60.0  # merged over reprocess's defaults


def test_overrides() -> None:
    cfg = ReprocessConfig().with_overrides({"kpi.time_gap_s": 1.0, "fit.kappa": 3.0})
    assert cfg.kpi.time_gap_s == 1.0
    assert cfg.fit["kappa"] == 3.0
    with pytest.raises(ConfigError):
        ReprocessConfig().with_overrides({"kpi.nope": 1})


def test_tf_extrinsics_round_trip() -> None:
    cam = load_camera("sim_default")
    extr = extrinsics_from_tf(cam.extrinsics.position, camera_quaternion_xyzw(cam))
    assert extr.height_m == pytest.approx(1.5)
    assert extr.pitch_rad == pytest.approx(0.06)
    assert extr.roll_rad == pytest.approx(0.0, abs=1e-9)


def test_mobileye_sign_is_flipped_to_left_positive() -> None:
    rows = []
    for t in (0, 100_000_000):
        for msg, sig, val in (
            ("Left_Lane_A", "Curve_Parameter_C2", -0.001),  # right-positive: bends left
            ("Left_Lane_A", "Quality", 3.0),
            ("Left_Lane_A", "Curve_Parameter_C0", -1.8),
            ("Right_Lane_A", "Curve_Parameter_C2", -0.001),
            ("Right_Lane_A", "Quality", 3.0),
            ("Right_Lane_A", "Curve_Parameter_C0", 1.7),
        ):
            rows.append({"log_time_ns": t, "message": msg, "signal": sig, "value": val})
    table = mobileye_table(pd.DataFrame(rows))
    assert np.allclose(table["curvature"], 0.002)
    assert np.allclose(table["left_a0_m"], 1.8)
    assert np.allclose(table["right_a0_m"], -1.7)


def test_rtk_flags_degraded_fixes_and_dropouts() -> None:
    t = np.arange(0, 20_000_000_000, 100_000_000, dtype=np.int64)
    t = np.concatenate([t[:100], t[110:]])  # 1 s dropout
    radius = 200.0
    ang = 25.0 * t / 1e9 / radius
    lat0, lon0 = 48.0, 11.0
    east, north = radius * np.sin(ang), radius * (1 - np.cos(ang))  # left turn
    lat = lat0 + north / 111_200.0
    lon = lon0 + east / (111_200.0 * np.cos(np.radians(lat0)))
    status = np.full(t.size, 2)
    status[20:25] = 0
    rows = [
        {
            "topic": "/fix",
            "log_time_ns": int(ti),
            "latitude_deg": la,
            "longitude_deg": lo,
            "altitude_m": 500.0,
            "fix_status": int(s),
            "covariance_m2": [1e-4, 0, 0, 0, 1e-4, 0, 0, 0, 1e-4],
        }
        for ti, la, lo, s in zip(t, lat, lon, status, strict=True)
    ]
    frames = np.arange(0, 20_000_000_000, 66_666_667, dtype=np.int64)
    truth = rtk_truth(GnssFixes.from_rows(rows), frames, RtkConfig())
    assert truth.n_degraded == 5
    assert truth.n_dropouts == 1
    assert (~truth.fixes["good"].iloc[20:25]).all()
    assert truth.fixes["flag"].iloc[20].startswith("not RTK fixed")
    valid = truth.frame_curvature[np.isfinite(truth.frame_curvature)]
    assert valid.size > 50
    assert np.median(valid) == pytest.approx(1 / radius, rel=0.05)
