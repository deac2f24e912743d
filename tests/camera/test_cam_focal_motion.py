"""The focal length from dashed markings moving between frames at a known distance."""

from __future__ import annotations

import math
from itertools import pairwise
from pathlib import Path

import numpy as np
import pytest

from superlane_tools.camera.extrinsics_estimate import (
    estimate_extrinsics,
    frame_lines,
    intrinsics_from_hfov,
)
from superlane_tools.camera.focal_motion import dash_profiles, focal_from_motion
from superlane_tools.camera.model import CameraModel, Extrinsics
from superlane_tools.commands.camera_estimate import estimate_camera
from superlane_tools.simulation.drive import sim_camera, simulate_drive


def _marking_pixels(cam: CameraModel, travelled_m: float) -> np.ndarray:
    """Pixels of a solid left line and a dashed right line (3 m dashes, 9 m gaps), 4 cm steps."""
    xs = np.arange(4.0, 80.0, 0.04)
    pts = []
    for y, dashed in ((1.8, False), (-1.9, True)):
        keep = ((xs + travelled_m) % 12.0 < 3.0) if dashed else np.ones_like(xs, dtype=bool)
        for dy in np.linspace(-0.07, 0.07, 5):  # 15 cm wide markings
            ground = np.stack([xs[keep], np.full(keep.sum(), y + dy), np.zeros(keep.sum())], 1)
            uv, ok = cam.project(ground)
            pts.append(uv[ok])
    uv = np.round(np.concatenate(pts))
    inside = (uv[:, 0] >= 0) & (uv[:, 0] < cam.width) & (uv[:, 1] >= 0) & (uv[:, 1] < cam.height)
    return np.unique(uv[inside], axis=0)


def test_focal_length_from_dash_motion_with_a_wrong_assumed_lens() -> None:
    truth = CameraModel(
        intrinsics_from_hfov(640, 360, 75.0), Extrinsics(1.3, pitch_rad=0.05, roll_rad=0.01)
    )
    assumed = intrinsics_from_hfov(640, 360, 55.0)  # 38 % too long a focal length
    step = 2.5  # metres between frames
    frames = [_marking_pixels(truth, i * step) for i in range(30)]
    lines = [frame_lines(uv, assumed, seed=i) for i, uv in enumerate(frames)]
    # a frame whose nearest dash is in a gap has too few near pixels on that side
    assert sum(fl is not None for fl in lines) >= 20
    est = estimate_extrinsics(lines, assumed, lane_width_m=3.7, roll_rad=0.01).extrinsics
    profiles = [
        dash_profiles(uv, fl, assumed, est) if fl is not None else None
        for uv, fl in zip(frames, lines, strict=True)
    ]
    pairs = [(a, b, step) for a, b in pairwise(profiles) if a is not None and b is not None]
    assert len(pairs) >= 12
    found = focal_from_motion(pairs, est, 640, 360)
    assert found is not None
    assert found.pairs >= len(pairs)  # at least the dashed side of every frame pair
    assert found.focal_px == pytest.approx(truth.intrinsics.fx, rel=0.06)  # measured: +4 %
    # no motion, or frames too far apart to follow a dash: no answer rather than a wrong one
    assert focal_from_motion([(a, b, 0.0) for a, b, _ in pairs], est, 640, 360) is None
    assert focal_from_motion([(a, b, 20.0) for a, b, _ in pairs], est, 640, 360) is None


@pytest.mark.slow
@pytest.mark.parametrize(("scenario", "seed"), [("highway_straight", 107), ("highway_curves", 108)])
def test_estimate_without_intrinsics_measures_the_focal_length(
    tmp_path: Path, scenario: str, seed: int
) -> None:
    rec = tmp_path / "drive.mcap"
    simulate_drive(scenario, 3.0, seed, "mcap", 320, 180, False, rec, fps=10.0)
    truth = sim_camera(320, 180)
    result = estimate_camera(rec, lane_width_m=3.7, max_frames=30)
    assert "MEASURED" in result.intrinsics_source
    assert result.camera.intrinsics.fx == pytest.approx(truth.intrinsics.fx, rel=0.06)
    e = result.estimate.extrinsics
    assert abs(math.degrees(e.pitch_rad - truth.extrinsics.pitch_rad)) < 0.3
    assert abs(e.height_m / truth.extrinsics.height_m - 1.0) < 0.10


def test_estimate_at_a_low_frame_rate_keeps_the_assumed_lens_and_says_why(
    tmp_path: Path,
) -> None:
    rec = tmp_path / "drive.mcap"
    simulate_drive("highway_straight", 4.0, 109, "mcap", 320, 180, False, rec, fps=2.0)
    result = estimate_camera(rec, max_frames=4)  # every second frame, 1 s (~30 m) apart
    assert "ASSUMED" in result.intrinsics_source
    assert "consecutive frames more than 5 m apart" in result.intrinsics_source
    assert result.camera.intrinsics.fx == pytest.approx(intrinsics_from_hfov(320, 180, 60.0).fx)
