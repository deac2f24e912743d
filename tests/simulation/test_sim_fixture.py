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
    # 6.94 MB as committed: a bound with 5 % headroom catches a fixture that grew by accident.
    assert SAMPLE.stat().st_size <= 7_300_000
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


def _messages(path: Path) -> list[tuple[str, int, bytes]]:
    from mcap.reader import make_reader

    with path.open("rb") as handle:
        return [
            (channel.topic, message.log_time, bytes(message.data))
            for _, channel, message in make_reader(handle).iter_messages(log_time_order=True)
        ]


def _jpeg(payload: bytes) -> np.ndarray:
    import cv2

    image = cv2.imdecode(np.frombuffer(payload[payload.index(b"\xff\xd8") :], np.uint8), 1)
    assert image is not None
    return np.asarray(image, dtype=np.int16)


@pytest.mark.slow
def test_regenerating_the_fixture_gives_the_committed_recording(
    config: dict[str, object], tmp_path: Path
) -> None:
    """Run the README's command and compare the recording message by message.

    Every CAN, GNSS, CameraInfo and TF payload and every log time must be byte-identical. JPEG
    frames must be too, except where floating-point rounding on another machine moves a few
    pixels by a grey level (measured: 1 frame of 240, 0.01 % of its pixels, by at most 2).
    """
    from superlane_tools.simulation.drive import simulate_drive

    out = tmp_path / "sample_drive.mcap"
    width, height = int(config["width"]), int(config["height"])  # type: ignore[call-overload]
    simulate_drive(
        str(config["scenario"]),
        float(config["duration_s"]),  # type: ignore[arg-type]
        int(config["seed"]),  # type: ignore[call-overload]
        "mcap",
        width,
        height,
        False,
        out,
        fps=float(config["fps"]),  # type: ignore[arg-type]
        jpeg_quality=int(config["jpeg_quality"]),  # type: ignore[call-overload]
        start_ns=int(config["start_ns"]),  # type: ignore[call-overload]
    )
    mine, committed = _messages(out), _messages(SAMPLE)
    assert [m[:2] for m in mine] == [m[:2] for m in committed]
    differing = [(a, b) for a, b in zip(mine, committed, strict=True) if a[2] != b[2]]
    assert all(a[0] == TOPIC_IMAGE for a, _ in differing), [a[0] for a, _ in differing]
    assert len(differing) <= 0.02 * len(committed)
    for a, b in differing:
        diff = np.abs(_jpeg(a[2]) - _jpeg(b[2]))
        assert diff.max() <= 4
        assert (diff > 0).mean() < 0.005
    gt_new = pd.read_parquet(out.with_name("sample_drive.gt.parquet"))
    gt_old = pd.read_parquet(GT)
    assert list(gt_new.columns) == list(gt_old.columns)
    assert len(gt_new) == len(gt_old)
