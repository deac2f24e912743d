"""Camera models for real cameras: chessboard calibration and extrinsics from lane lines."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml
from typer.testing import CliRunner

from superlane_tools.camera import load_camera
from superlane_tools.camera.calibration import calibrate_chessboard, parse_board
from superlane_tools.camera.errors import CameraError
from superlane_tools.camera.extrinsics_estimate import (
    estimate_extrinsics,
    frame_lines,
    intrinsics_from_hfov,
)
from superlane_tools.camera.model import CameraModel, Extrinsics
from superlane_tools.cli.app import app
from superlane_tools.commands.camera_estimate import estimate_camera
from superlane_tools.simulation.drive import sim_camera, simulate_drive

runner = CliRunner()


def test_udacity_chessboards_calibrate_into_a_profile(realdata: Path, tmp_path: Path) -> None:
    folder = realdata / "udacity" / "advanced_lane_lines" / "camera_cal"
    out = tmp_path / "udacity.yaml"
    result = runner.invoke(
        app, ["camera", "calibrate", str(folder), "--board", "9x6", "-o", str(out)]
    )
    assert result.exit_code == 3, result.output  # a profile, but some photos were not used
    data = yaml.safe_load(out.read_text(encoding="utf-8"))
    cal = data["calibration"]
    assert 0.1 < cal["reprojection_rms_px"] < 1.5
    assert cal["views_used"] >= 12
    cam = load_camera(out)
    k = cam.intrinsics
    assert (k.width, k.height) == (1280, 720)
    assert 1000 < k.fx < 1300
    assert abs(k.fx - k.fy) / k.fx < 0.02
    assert k.dist[0] < -0.1  # a dashcam's barrel distortion
    assert "reprojection error" in result.stderr
    skipped = [line for line in result.stderr.splitlines() if line.startswith("slt: skipped:")]
    assert len(skipped) == 2, result.stderr  # one line per kind, with a count
    no_board = "slt: skipped: photos, no complete 9x6 board found (3): "
    assert skipped[0].startswith(no_board), skipped  # a corner is cut off in these photos
    assert "calibration1.jpg" in skipped[0]
    assert "(2): " in skipped[1]  # 1281x721 photos among 1280x720
    assert cal["views_used"] == 20 - 5


def test_calibration_needs_boards(tmp_path: Path) -> None:
    blank = tmp_path / "blank.png"
    import cv2

    cv2.imwrite(str(blank), np.full((60, 80), 128, np.uint8))
    with pytest.raises(CameraError, match="complete 9x6 board"):
        calibrate_chessboard([blank] * 3)
    with pytest.raises(CameraError):
        parse_board("9by6")
    result = runner.invoke(app, ["camera", "calibrate", str(blank)])
    assert result.exit_code == 1
    assert result.stderr.startswith("slt: error: only 0 of 1 images")


def _synthetic_lines(cam: CameraModel, width_m: float, left_m: float) -> np.ndarray:
    xs = np.linspace(6.0, 40.0, 200)
    pts = []
    for y in (left_m, left_m - width_m, left_m + width_m):
        ground = np.stack([xs, np.full_like(xs, y), np.zeros_like(xs)], 1)
        uv, ok = cam.project(ground)
        pts.append(uv[ok])
    uv = np.concatenate(pts)
    inside = (uv[:, 0] >= 0) & (uv[:, 0] < cam.width) & (uv[:, 1] >= 0) & (uv[:, 1] < cam.height)
    return uv[inside]


def test_vanishing_point_geometry_recovers_a_known_mount() -> None:
    k = intrinsics_from_hfov(640, 360, 70.0)
    truth = Extrinsics(
        1.4, pitch_rad=math.radians(2.5), roll_rad=math.radians(1.5), yaw_rad=math.radians(1.0)
    )
    cam = CameraModel(k, truth)
    # the camera wanders +-0.2 m about the lane centre (left line 1.75 m to its left)
    offsets = [-0.2, -0.1, 0.0, 0.1, 0.2]
    lines = [
        frame_lines(_synthetic_lines(cam, 3.5, 1.75 + o), k, seed=i) for i, o in enumerate(offsets)
    ]
    est = estimate_extrinsics(lines, k, lane_width_m=3.5)
    assert est.frames_used == 5
    assert abs(est.extrinsics.roll_rad - truth.roll_rad) < math.radians(0.05)
    assert abs(est.extrinsics.pitch_rad - truth.pitch_rad) < math.radians(0.02)
    assert abs(est.extrinsics.yaw_rad - truth.yaw_rad) < math.radians(0.05)
    assert abs(est.extrinsics.height_m - 1.4) < 0.01
    assert est.summary()["roll_method"].startswith("lane centred on average")
    # a given roll is used as is; without it this camera's pitch and yaw come out wrong
    fixed = estimate_extrinsics(lines, k, lane_width_m=3.5, roll_rad=0.0)
    assert fixed.extrinsics.roll_rad == 0.0
    assert fixed.summary()["roll_method"] == "given"
    assert abs(fixed.extrinsics.yaw_rad - truth.yaw_rad) > math.radians(0.05)
    with pytest.raises(CameraError, match="both ego lane lines"):
        estimate_extrinsics([None, None], k)


@pytest.mark.slow
@pytest.mark.parametrize(("scenario", "seed"), [("highway_straight", 101), ("highway_curves", 102)])
def test_estimate_recovers_pitch_and_height_of_held_out_drives(
    tmp_path: Path, scenario: str, seed: int
) -> None:
    rec = tmp_path / "drive.mcap"
    simulate_drive(scenario, 3.0, seed, "mcap", 320, 180, False, rec, fps=10.0)
    truth = sim_camera(320, 180)
    result = estimate_camera(rec, intrinsics=truth.intrinsics, lane_width_m=3.7, max_frames=30)
    e = result.estimate.extrinsics
    assert abs(math.degrees(e.pitch_rad - truth.extrinsics.pitch_rad)) < 0.3
    assert abs(e.height_m / truth.extrinsics.height_m - 1.0) < 0.10
    assert result.estimate.frames_used >= 20


@pytest.mark.slow
def test_estimate_recovers_the_roll_of_a_held_out_drive(tmp_path: Path) -> None:
    # roll comes from the lane being centred on average: the drive must be long enough for the
    # simulator's lateral wander (120-400 m wavelengths) to average out
    rec = tmp_path / "drive.mcap"
    roll = math.radians(-1.2)
    simulate_drive(
        "highway_straight", 60.0, 105, "mcap", 320, 180, False, rec, fps=2.0, camera_roll_rad=roll
    )
    truth = sim_camera(320, 180)
    result = estimate_camera(rec, intrinsics=truth.intrinsics, max_frames=60)
    est = result.estimate
    assert abs(math.degrees(est.extrinsics.roll_rad - roll)) < 0.75
    assert abs(math.degrees(est.extrinsics.pitch_rad - truth.extrinsics.pitch_rad)) < 0.3
    assert abs(est.extrinsics.height_m / truth.extrinsics.height_m - 1.0) < 0.10
    assert est.roll_sigma_rad is not None
    assert est.summary()["roll_deg"] == pytest.approx(
        math.degrees(est.extrinsics.roll_rad), abs=1e-3
    )


def test_estimate_cli_without_intrinsics_says_what_it_assumed(tmp_path: Path) -> None:
    rec = tmp_path / "drive.mcap"
    # 3 s: the real-trained default model's dashes need more than 9 frames to align (1.5 s and
    # 9 frames: "no clear dash pattern alignment"; 3 s and 18 frames: 255 px, the truth 250 px)
    simulate_drive("highway_curves", 3.0, 103, "mcap", 320, 180, False, rec, fps=6.0)
    out = tmp_path / "est.yaml"
    result = runner.invoke(app, ["camera", "estimate", str(rec), "-o", str(out), "--frames", "18"])
    assert result.exit_code == 0, result.output
    assert "MEASURED from the dashed markings' motion at GNSS speed" in result.stderr
    assert "MEASURED" in yaml.safe_load(out.read_text(encoding="utf-8"))["estimate"]["intrinsics"]
    # without GNSS the focal length cannot be measured: the assumed lens stays, and says so
    bare = tmp_path / "no_gnss.mcap"
    cut = runner.invoke(app, ["filter", str(rec), "-o", str(bare), "--exclude", "gnss"])
    assert cut.exit_code == 0, cut.output
    out = tmp_path / "assumed.yaml"
    result = runner.invoke(app, ["camera", "estimate", str(bare), "-o", str(out), "--frames", "9"])
    assert result.exit_code == 0, result.output
    assert "ASSUMED" in result.stderr
    assert "no GNSS track" in result.stderr
    data = yaml.safe_load(out.read_text(encoding="utf-8"))
    assert data["estimate"]["frames_used"] >= 3
    assert "ASSUMED" in data["estimate"]["intrinsics"]
    cam = load_camera(out)
    assert abs(math.degrees(cam.extrinsics.pitch_rad) - 3.44) < 1.0  # sim camera: 3.44 deg


def _reprocessed_median_width(rec: Path, profile: Path, run: Path) -> float:
    result = runner.invoke(
        app, ["reprocess", str(rec), "--camera", str(profile), "-o", str(run), "--no-plots"]
    )
    assert result.exit_code in (0, 3), result.output
    widths = pd.read_parquet(run / "lanes.parquet")["lane_width"].dropna()
    assert len(widths) >= 6
    return float(widths.median())


@pytest.mark.slow
def test_a_profile_estimated_from_a_simulated_drive_reproduces_its_lane_width(
    tmp_path: Path,
) -> None:
    rec = tmp_path / "drive.mcap"
    simulate_drive("highway_straight", 3.0, 106, "mcap", 320, 180, False, rec, fps=10.0)
    profile = tmp_path / "est.yaml"
    args = ["camera", "estimate", str(rec), "--intrinsics", "sim_default", "--frames", "30"]
    result = runner.invoke(app, [*args, "-o", str(profile)])
    assert result.exit_code == 0, result.output
    est = yaml.safe_load(profile.read_text(encoding="utf-8"))["estimate"]
    assert est["height_fit_frames"] >= 20
    assert abs(est["height_m"] / sim_camera(320, 180).extrinsics.height_m - 1.0) < 0.03
    width = _reprocessed_median_width(rec, profile, tmp_path / "run")
    assert abs(width / 3.7 - 1.0) < 0.03, width  # the simulator's lanes are 3.7 m


def _mp4(path: Path, images: list[np.ndarray], fps: int) -> Path:
    from fractions import Fraction

    import av

    height, width = images[0].shape[:2]
    with av.open(str(path), "w") as container:
        stream = container.add_stream("libx264", rate=fps)
        stream.width, stream.height, stream.pix_fmt = width, height, "yuv420p"
        stream.codec_context.time_base = Fraction(1, fps)
        stream.codec_context.options = {"bf": "0", "crf": "18"}
        for img in images:
            for packet in stream.encode(av.VideoFrame.from_ndarray(img, format="bgr24")):
                container.mux(packet)
        for packet in stream.encode(None):
            container.mux(packet)
    return path


@pytest.mark.slow
@pytest.mark.parametrize(
    ("images", "count"),
    [("tusimple/train_frames/images", 24), ("udacity/advanced_lane_lines/test_images", 8)],
    ids=["tusimple", "udacity"],
)
def test_a_profile_estimated_from_a_real_clip_reproduces_its_lane_width(
    realdata: Path, tmp_path: Path, images: str, count: int
) -> None:
    # the lens is unknown (60 degrees assumed): before the height came from the fit, the
    # Udacity clip reprocessed to a median of 4.34 m for an assumed 3.7 m
    import cv2

    frames = [cv2.imread(str(p)) for p in sorted((realdata / images).glob("*.jpg"))[:count]]
    rec = tmp_path / "clip.mcap"
    mp4 = _mp4(tmp_path / "clip.mp4", frames, fps=5)
    assert runner.invoke(app, ["convert", str(mp4), "-o", str(rec)]).exit_code == 0
    profile = tmp_path / "est.yaml"
    args = ["camera", "estimate", str(rec), "--frames", str(count), "-o", str(profile)]
    result = runner.invoke(app, args)
    assert result.exit_code == 0, result.output
    width = _reprocessed_median_width(rec, profile, tmp_path / "run")
    assert abs(width / 3.7 - 1.0) < 0.03, width
