"""Camera profiles: bundled names, YAML files, the TuSimple estimate and its pipeline script."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from superlane_tools.camera import (
    CameraError,
    CameraModel,
    LaneCalibrationParams,
    camera_from_yaml,
    camera_to_yaml,
    estimate_camera_from_lanes,
    ground_to_image,
    list_profiles,
    load_camera,
)
from superlane_tools.evaluation import load_jsonl

REPO = Path(__file__).resolve().parents[2]
SCRIPT = REPO / "pipelines" / "estimate_tusimple_camera.py"


def test_bundled_profiles_are_listed_and_load() -> None:
    names = list_profiles()
    assert {"sim_default", "tusimple", "kitti"} <= set(names)
    for name in names:
        cam = load_camera(name)
        assert cam.name == name


def test_sim_default_has_exactly_the_simulator_values() -> None:
    cam = load_camera("sim_default")
    k, e = cam.intrinsics, cam.extrinsics
    assert (k.width, k.height, k.fx, k.fy, k.cx, k.cy) == (1280, 720, 1000.0, 1000.0, 639.5, 359.5)
    assert k.dist == (0.0, 0.0, 0.0, 0.0, 0.0)
    assert (e.height_m, e.pitch_rad, e.roll_rad, e.yaw_rad) == (1.5, 0.06, 0.0, 0.0)


def test_yaml_round_trip_through_a_file(tmp_path: Path) -> None:
    cam = load_camera("kitti")
    path = tmp_path / "my camera.yaml"
    path.write_text(camera_to_yaml(cam, comment="a comment\n\nsecond line"), encoding="utf-8")
    text = path.read_text(encoding="utf-8")
    assert text.startswith("# a comment\n#\n# second line\n")
    assert load_camera(path) == cam
    assert load_camera(str(path)) == cam
    assert camera_from_yaml(text) == cam


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("intrinsics: [1, 2\n", "not valid YAML"),
        ("- 1\n- 2\n", "expected a mapping"),
        ("intrinsics: {width: 10}\nextrinsics: {height_m: 1}\n", "invalid camera"),
    ],
)
def test_bad_yaml_files_raise_camera_errors(tmp_path: Path, text: str, match: str) -> None:
    path = tmp_path / "bad.yaml"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(CameraError, match=match):
        load_camera(path)


def test_unknown_profile_and_missing_file_raise_camera_errors(tmp_path: Path) -> None:
    with pytest.raises(CameraError, match=r"unknown camera profile 'nope'.*sim_default"):
        load_camera("nope")
    with pytest.raises(CameraError, match="cannot read camera file"):
        load_camera(tmp_path / "missing.yaml")


def _synthetic_tusimple_frames(
    cam: CameraModel, seed: int
) -> list[tuple[list[list[float]], list[float]]]:
    """Project straight lanes 3.75 m apart onto TuSimple rows, rounded to whole pixels."""
    rng = np.random.default_rng(seed)
    rows = np.arange(160.0, 720.0, 10.0)
    frames = []
    for _ in range(40):
        offset = rng.uniform(-1.0, 1.0)
        lanes = []
        for k in (-2, -1, 0, 1):
            y = (k + 0.5) * 3.75 + offset
            x = np.geomspace(3.0, 400.0, 4000)
            uv = ground_to_image(cam, x, np.full_like(x, y))
            order = np.argsort(uv[:, 1])
            u_at = np.interp(rows, uv[order, 1], uv[order, 0], left=-2.0, right=-2.0)
            ok = (u_at >= 0) & (u_at < cam.width) & (rows > cam.horizon_row() + 15)
            lanes.append(np.where(ok, np.round(u_at), -2.0).tolist())
        frames.append((lanes, rows.tolist()))
    return frames


@pytest.mark.parametrize(("pitch", "yaw", "height"), [(0.12, 0.014, 1.72), (0.05, -0.02, 1.3)])
def test_lane_calibration_recovers_a_known_camera(pitch: float, yaw: float, height: float) -> None:
    truth = CameraModel.from_dict(
        {
            "intrinsics": {
                "width": 1280,
                "height": 720,
                "fx": 1000,
                "fy": 1000,
                "cx": 639.5,
                "cy": 359.5,
            },
            "extrinsics": {"height_m": height, "pitch_rad": pitch, "yaw_rad": yaw},
        }
    )
    result = estimate_camera_from_lanes(
        _synthetic_tusimple_frames(truth, 1), LaneCalibrationParams()
    )
    est = result.camera.extrinsics
    assert result.n_frames_used == 40
    assert est.pitch_rad == pytest.approx(pitch, abs=1e-3)
    assert est.yaw_rad == pytest.approx(yaw, abs=1e-3)
    assert est.height_m == pytest.approx(height, rel=0.02)
    assert result.summary()["horizon_row_mad_px"] < 1.0


def test_lane_calibration_needs_straight_lane_pairs() -> None:
    rows = [float(v) for v in range(240, 720, 10)]
    one_lane = [[float(400 + (r - 240)) for r in rows]]
    with pytest.raises(CameraError, match="none of 1 frames"):
        estimate_camera_from_lanes([(one_lane, rows)])


def test_bundled_tusimple_profile_is_what_the_train_labels_give(realdata: Path) -> None:
    files = sorted((realdata / "tusimple" / "train_labels").glob("label_data_*.json"))
    assert len(files) == 3
    frames = [(r.lanes, r.h_samples) for f in files for r in load_jsonl(f)]
    result = estimate_camera_from_lanes(frames, LaneCalibrationParams(), name="tusimple")
    bundled = load_camera("tusimple")
    assert bundled.intrinsics == result.camera.intrinsics
    got, want = bundled.extrinsics, result.camera.extrinsics
    assert got.pitch_rad == pytest.approx(want.pitch_rad, abs=1e-4)
    assert got.yaw_rad == pytest.approx(want.yaw_rad, abs=1e-4)
    assert got.height_m == pytest.approx(want.height_m, abs=1e-4)
    summary = result.summary()
    assert 225 < summary["horizon_row_median_px"] < 250
    assert summary["horizon_row_p95_px"] - summary["horizon_row_p5_px"] < 40


def test_estimate_script_writes_a_loadable_profile(realdata: Path, tmp_path: Path) -> None:
    src = realdata / "tusimple" / "train_labels" / "label_data_0601.json"
    out = tmp_path / "tusimple_0601.yaml"
    proc = subprocess.run(
        [sys.executable, str(SCRIPT), str(src), "--out", str(out)],
        capture_output=True,
        text=True,
        check=False,
        timeout=120,
    )
    assert proc.returncode == 0, proc.stderr
    cam = load_camera(out)
    assert cam.name == "tusimple"
    assert 0.08 < cam.extrinsics.pitch_rad < 0.16
    assert 1.2 < cam.extrinsics.height_m < 2.3
    assert "horizon row px: median" in out.read_text(encoding="utf-8")


def test_estimate_script_refuses_test_split_files(tmp_path: Path) -> None:
    bad = tmp_path / "test_label.json"
    bad.write_text("{}\n", encoding="utf-8")
    proc = subprocess.run(
        [sys.executable, str(SCRIPT), str(bad), "--out", str(tmp_path / "x.yaml")],
        capture_output=True,
        text=True,
        check=False,
        timeout=120,
    )
    assert proc.returncode != 0
    assert "train labels only" in proc.stderr
    assert not (tmp_path / "x.yaml").exists()
