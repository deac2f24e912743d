"""`slt extract` round trips: recordings written with the project's writers, read back."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from superlane_tools.cli.app import app
from superlane_tools.recording.messages import (
    camera_info,
    can_frame,
    compressed_image,
    navsatfix,
    raw_image,
)
from superlane_tools.recording.writers import open_writer
from superlane_tools.reporting import read_provenance

T0 = 1_700_000_000_000_000_000
MS = 1_000_000
DBC = """VERSION ""

NS_ :

BS_:

BU_: ECU

BO_ 256 Motion: 8 ECU
 SG_ Speed : 0|16@1+ (0.01,0) [0|655.35] "m/s" ECU
"""
runner = CliRunner()


def _jpeg(seed: int) -> bytes:
    rng = np.random.default_rng(seed)
    img = rng.integers(0, 255, (48, 64, 3), dtype=np.uint8)
    return cv2.imencode(".jpg", img)[1].tobytes()


def _write(path: Path, fmt: str, corrupt: int | None = None) -> list[bytes]:
    jpegs = [_jpeg(i) for i in range(10)]
    with open_writer(path, fmt) as w:  # type: ignore[arg-type]
        w.add_topic("/cam/front/compressed", "sensor_msgs/msg/CompressedImage")
        w.add_topic("/cam/front/camera_info", "sensor_msgs/msg/CameraInfo")
        w.add_topic("/cam/raw", "sensor_msgs/msg/Image")
        w.add_topic("/can", "can_msgs/msg/Frame")
        w.add_topic("/fix", "sensor_msgs/msg/NavSatFix")
        k = [100.0, 0, 32, 0, 100.0, 24, 0, 0, 1]
        for i in range(10):
            t = T0 + i * 100 * MS
            payload = b"\xff\xd8\xff\xe0garbage" if i == corrupt else jpegs[i]
            w.write("/cam/front/compressed", t, compressed_image(t, "cam", "jpeg", payload))
            w.write(
                "/cam/front/camera_info", t, camera_info(t, "cam", 64, 48, k, [0.1, 0, 0, 0, 0])
            )
            w.write("/cam/raw", t + MS, raw_image(t, "cam", np.full((4, 6), i, np.uint8), "mono8"))
            for j in range(10):
                tc = t + j * 10 * MS
                speed = int(1000 + 10 * i + j)
                w.write("/can", tc, can_frame(tc, 256, speed.to_bytes(2, "little") + b"\0" * 6))
            lat = 48.0 + i * 1e-5  # about 1.1 m north per 100 ms: 11 m/s
            w.write("/fix", t, navsatfix(t, "gps", lat, 11.0, 500.0, status=2))
    return jpegs


def _run(*args: str) -> object:
    return runner.invoke(app, ["extract", *map(str, args)], catch_exceptions=False)


@pytest.mark.parametrize(("fmt", "name"), [("mcap", "r.mcap"), ("ros1", "r.bag"), ("ros2", "r2")])
def test_round_trip(tmp_path: Path, fmt: str, name: str) -> None:
    rec = tmp_path / name
    jpegs = _write(rec, fmt)
    dbc = tmp_path / "m.dbc"
    dbc.write_text(DBC)
    out = tmp_path / "out"
    result = _run(rec, "--out", out, "--dbc", dbc)
    assert result.exit_code == 0, result.output  # type: ignore[attr-defined]
    frames = pd.read_parquet(out / "frames.parquet")
    comp = frames[frames["topic"] == "/cam/front/compressed"]
    assert len(comp) == 10
    assert comp["ok"].all()
    assert (comp["width"] == 64).all()
    assert (comp["height"] == 48).all()
    for row, jpeg in zip(comp.itertuples(), jpegs, strict=True):
        assert (out / row.path).read_bytes() == jpeg  # byte for byte
    assert row.path == "frames/cam_front_compressed/000009.jpg"
    raw = frames[frames["topic"] == "/cam/raw"]
    img = cv2.imread(str(out / raw["path"].iloc[3]), cv2.IMREAD_UNCHANGED)
    assert img.shape == (4, 6)
    assert (img == 3).all()
    info = pd.read_parquet(out / "camera_info.parquet")
    assert len(info) == 1
    assert info["k"][0][0] == 100.0
    assert info["width"][0] == 64
    can = pd.read_parquet(out / "can_raw.parquet")
    assert len(can) == 100
    assert (can["can_id"] == 256).all()
    assert (can["dlc"] == 8).all()
    signals = pd.read_parquet(out / "can_signals.parquet")
    assert signals["value"].tolist() == pytest.approx([(1000 + k) * 0.01 for k in range(100)])
    rtk = pd.read_parquet(out / "rtk.parquet")
    assert len(rtk) == 10
    assert (rtk["fix_status"] == 2).all()
    assert rtk["north_m"].iloc[-1] == pytest.approx(9e-5 * 111_195, rel=0.01)
    assert rtk["speed_mps"].median() == pytest.approx(11.1, rel=0.02)
    assert rtk["heading_rad"].median() == pytest.approx(np.pi / 2, abs=1e-3)
    prov = read_provenance(out / "rtk.parquet")
    assert prov["inputs"][0]["name"] == name
    assert "extract" in prov["command"]


def test_every_range_corrupt_and_png(tmp_path: Path) -> None:
    rec = tmp_path / "r.mcap"
    _write(rec, "mcap", corrupt=4)
    out = tmp_path / "out"
    result = _run(rec, "--out", out, "--every", "2", "--start", "0.2", "--end", "0.75",
                  "--frames", "png", "-t", "/cam/front/compressed", "-t", "/fix")  # fmt: skip
    assert result.exit_code == 3, result.output  # type: ignore[attr-defined]
    assert "corrupt image" in result.output  # type: ignore[attr-defined]
    frames = pd.read_parquet(out / "frames.parquet")
    assert frames["index"].tolist() == [0, 2, 4]  # frames 2, 4, 6 of the recording
    assert frames["log_time_ns"].tolist() == [T0 + k * 100 * MS for k in (2, 4, 6)]
    assert frames["ok"].tolist() == [True, False, True]
    assert frames["path"].iloc[1] == ""
    assert frames["error"].iloc[1]
    png = (out / frames["path"].iloc[0]).read_bytes()
    assert png.startswith(b"\x89PNG")
    assert not (out / "can_raw.parquet").exists()
    assert len(pd.read_parquet(out / "rtk.parquet")) == 6  # fixes 2..7


def test_config_none_frames_and_origin(tmp_path: Path) -> None:
    rec = tmp_path / "r.mcap"
    _write(rec, "mcap")
    cfg = tmp_path / "c.yaml"
    cfg.write_text("frames: [/cam/raw]\ngnss: [/fix]\ncan: []\n")
    out = tmp_path / "out"
    result = _run(rec, "--out", out, "--config", cfg, "--frames", "none", "--origin", "48,11,500")
    assert result.exit_code == 0, result.output  # type: ignore[attr-defined]
    frames = pd.read_parquet(out / "frames.parquet")
    assert set(frames["topic"]) == {"/cam/raw"}
    assert (frames["path"] == "").all()
    assert not (out / "frames").exists()
    assert not (out / "can_raw.parquet").exists()
    rtk = pd.read_parquet(out / "rtk.parquet")
    assert rtk["north_m"].iloc[0] == pytest.approx(0.0, abs=1e-6)
    assert rtk["up_m"].iloc[0] == pytest.approx(0.0, abs=1e-6)


@pytest.mark.parametrize(
    ("args", "code", "text"),
    [
        (["--every", "0"], 2, ""),
        (["--frames", "gif"], 2, "frame format"),
        (["-t", "/nope"], 2, "not in the recording"),
        (["--origin", "x,y"], 2, "origin"),
        (["--start", "2", "--end", "1"], 2, "--end"),
    ],
)
def test_usage_errors(tmp_path: Path, args: list[str], code: int, text: str) -> None:
    rec = tmp_path / "r.mcap"
    _write(rec, "mcap")
    result = _run(rec, "--out", tmp_path / "o", *args)
    assert result.exit_code == code, result.output  # type: ignore[attr-defined]
    assert text in result.output  # type: ignore[attr-defined]
    assert "Traceback" not in result.output  # type: ignore[attr-defined]


def test_not_a_recording_and_bad_config(tmp_path: Path) -> None:
    junk = tmp_path / "junk.mcap"
    junk.write_bytes(b"not mcap at all")
    result = _run(junk, "--out", tmp_path / "o")
    assert result.exit_code == 1
    assert "slt: error" in result.output
    cfg = tmp_path / "c.yaml"
    cfg.write_text("lidar: [/x]\n")
    result = _run(junk, "--out", tmp_path / "o", "--config", cfg)
    assert result.exit_code == 2
    assert "unknown key" in result.output


def test_real_bag_fix(realdata: Path, tmp_path: Path) -> None:
    result = _run(realdata / "bags/ros1_robot_localization/test1.bag", "--out", tmp_path)
    assert result.exit_code == 0, result.output  # type: ignore[attr-defined]
    rtk = pd.read_parquet(tmp_path / "rtk.parquet")
    assert len(rtk) == 989
    north_extent = rtk["north_m"].max() - rtk["north_m"].min()
    east_extent = rtk["east_m"].max() - rtk["east_m"].min()
    assert max(north_extent, east_extent) == pytest.approx(146, abs=3)
    assert min(north_extent, east_extent) == pytest.approx(57, abs=3)
    assert rtk["speed_mps"].median() < 3.0  # a Husky robot


def test_real_ford_log_speed(realdata: Path, tmp_path: Path) -> None:
    log = realdata / "can_logs/ford_fusion/car_60km.log"
    dbc = realdata / "dbc/opendbc/ford_lincoln_base_pt.dbc"
    result = _run(log, "--out", tmp_path, "--dbc", dbc)
    assert result.exit_code == 0, result.output  # type: ignore[attr-defined]
    signals = pd.read_parquet(tmp_path / "can_signals.parquet")
    speed = signals[(signals["can_id"] == 0x415) & (signals["signal"] == "Veh_V_ActlBrk")]
    assert len(speed) > 100
    assert 57.0 <= speed["value"].median() <= 58.5  # km/h
    assert len(pd.read_parquet(tmp_path / "can_raw.parquet")) == 18914


def test_real_messy_dbc_repairs_are_printed(realdata: Path, tmp_path: Path) -> None:
    log = realdata / "can_logs/ford_fusion/lane_keep_assist_in_yellow.log"
    dbc = realdata / "dbc/mobileye/Mobileye.dbc"
    result = _run(log, "--out", tmp_path, "--dbc", dbc)
    # A Mobileye DBC on a Ford powertrain log matches no id: a wrong DBC is partial (exit 3).
    assert result.exit_code == 3, result.output  # type: ignore[attr-defined]
    assert "no CAN id matched by any DBC" in result.output  # type: ignore[attr-defined]
    assert "Mobileye.dbc: loaded with 4 repair(s) (--verbose" in result.output  # type: ignore[attr-defined]
    assert "dropped VAL_ table" not in result.output  # type: ignore[attr-defined]
    verbose = _run(log, "--out", tmp_path / "v", "--dbc", dbc, "--verbose")
    assert verbose.exit_code == 3, verbose.output  # type: ignore[attr-defined]
    assert "dropped VAL_ table" in verbose.output  # type: ignore[attr-defined]


def test_real_nmea(realdata: Path, tmp_path: Path) -> None:
    result = _run(realdata / "gnss/nmea.log", "--out", tmp_path)
    assert result.exit_code == 0, result.output  # type: ignore[attr-defined]
    rtk = pd.read_parquet(tmp_path / "rtk.parquet")
    assert len(rtk) == 120
    assert (rtk["rtk_quality"] == 4).all()
    assert (rtk["fix_status"] == 2).all()
    assert np.hypot(rtk["east_m"], rtk["north_m"]).max() < 0.5  # creeps ~6 mm/s for a minute
    assert rtk["speed_mps"].median() == pytest.approx(0.006, abs=0.004)  # RMC: ~0.011 kn
