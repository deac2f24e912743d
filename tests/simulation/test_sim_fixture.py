"""The bundled sample drive: documented command, content, and a world that is still current."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from superlane_tools.camera.profiles import load_camera
from superlane_tools.recording import open_recording
from superlane_tools.reporting import read_provenance
from superlane_tools.simulation.drive import TOPIC_IMAGE
from superlane_tools.simulation.groundtruth import gt_row, lane_truth
from superlane_tools.simulation.scenarios import get_scenario
from superlane_tools.simulation.world import build_world, frame_world

FIXTURES = Path(__file__).resolve().parents[2] / "fixtures"
SAMPLE = FIXTURES / "sample_drive.mcap"
GT = FIXTURES / "sample_drive.gt.parquet"


@pytest.fixture(scope="module")
def config() -> dict[str, object]:
    if not SAMPLE.is_file():
        pytest.fail("fixtures/sample_drive.mcap is missing; see fixtures/README.md")
    cfg: dict[str, object] = read_provenance(GT)["config"]
    return cfg


def test_readme_names_the_command_that_made_the_fixture(config: dict[str, object]) -> None:
    readme = (FIXTURES / "README.md").read_text()
    line = next(ln for ln in readme.splitlines() if "sample_drive.mcap" in ln and "slt" in ln)
    for key, flag in (
        ("scenario", "--scenario"),
        ("seed", "--seed"),
        ("width", "--width"),
        ("height", "--height"),
        ("jpeg_quality", "--jpeg-quality"),
    ):
        assert f"{flag} {config[key]}" in line
    assert f"--duration {config['duration_s']:g}" in line


def test_fixture_is_small_and_has_curves_a_hill_and_a_leader(config: dict[str, object]) -> None:
    assert SAMPLE.stat().st_size <= 10 * 1024 * 1024
    assert 15.0 <= float(config["duration_s"]) <= 20.0  # type: ignore[arg-type]
    gt = pd.read_parquet(GT)
    assert gt["path_curvature"].abs().max() > 2e-3
    assert gt["road_slope"].abs().max() > 0.01
    assert gt["lead_gap_m"].notna().mean() > 0.9
    with open_recording(SAMPLE) as rec:
        counts = {t.topic: t.message_count for t in rec.topics()}
    assert counts[TOPIC_IMAGE] == len(gt)


def test_fixture_world_is_current(config: dict[str, object]) -> None:
    """Regenerate the fixture's ground-truth geometry (no rendering) and compare."""
    gt = pd.read_parquet(GT)
    width, height = int(config["width"]), int(config["height"])  # type: ignore[call-overload]
    camera = load_camera("sim_default").resized(width, height)
    world = build_world(
        get_scenario(str(config["scenario"])),
        int(config["seed"]),  # type: ignore[call-overload]
        float(config["duration_s"]),
    )  # type: ignore[arg-type]
    fps, start = float(config["fps"]), int(config["start_ns"])  # type: ignore[call-overload,arg-type]
    for i in range(0, len(gt), 17):
        fw = frame_world(world, i / fps, start + round(i * 1e9 / fps), camera, 0)
        row = gt_row(fw, lane_truth(fw), i)
        stored = gt.iloc[i]
        for key in (
            "t_ns",
            "speed_mps",
            "path_curvature",
            "east_m",
            "lane_curvature",
            "road_slope",
            "ego_lane_index",
            "corridor_length_m",
        ):
            assert np.isclose(float(row[key]), float(stored[key]), rtol=1e-9, atol=1e-12), key  # type: ignore[arg-type]
        assert list(row["line_offset_m"]) == pytest.approx(list(stored["line_offset_m"]))  # type: ignore[call-overload]
