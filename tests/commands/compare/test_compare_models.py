"""`slt compare` sees a weaker model and a wrong camera pitch (real reprocess runs, slow).

Two drives are too few for a verdict (docs/compare.md: 10), so these check the changes' signs
and that the verdict says so; the gate's verdicts on ten drives are in test_compare.py.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import pytest

from superlane_tools.camera.model import CameraModel
from superlane_tools.camera.profiles import camera_to_yaml
from superlane_tools.commands.compare import CompareParams, compare_runs
from superlane_tools.commands.reprocess import reprocess
from superlane_tools.drive.config import ReprocessConfig
from superlane_tools.fleet import TOO_FEW, UNPAIRED
from superlane_tools.reporting.run_folder import staged_run
from superlane_tools.simulation.drive import simulate_drive

pytestmark = pytest.mark.slow  # six reprocess runs with the segmentation network
QUICK = CompareParams(plots=False)
CONFIG = ReprocessConfig().with_overrides(
    {"kpi.window_s": 1.0, "output.plots": False, "output.example_frames": 0}
)


def _run(rec: Path, out: Path, config: ReprocessConfig) -> None:
    with staged_run(out) as stage:
        reprocess(rec, stage, config)


@pytest.fixture(scope="module")
def fleets(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    root = tmp_path_factory.mktemp("models")
    wrong = root / "wrong_pitch.yaml"
    for scenario, seed in (("highway_curves", 1), ("urban", 2)):
        rec = root / f"{scenario}.mcap"
        simulate_drive(scenario, 4.0, seed, "mcap", 640, 360, False, rec)
        if not wrong.exists():
            data = CameraModel.from_dict(  # the simulator's camera, pitched 0.04 rad too far
                {
                    "intrinsics": {
                        "width": 640,
                        "height": 360,
                        "fx": 500.0,
                        "fy": 500.0,
                        "cx": 319.5,
                        "cy": 179.5,
                    },
                    "extrinsics": {
                        "height_m": 1.5,
                        "pitch_rad": 0.10,
                        "roll_rad": 0.0,
                        "yaw_rad": 0.0,
                        "x_m": 0.0,
                        "y_m": 0.0,
                    },
                }
            )
            wrong.write_text(camera_to_yaml(data), encoding="utf-8")
        _run(rec, root / "base" / scenario, CONFIG)
        _run(
            rec,
            root / "v1" / scenario,
            CONFIG.with_overrides({"segmentation.model": "super_seg_v1"}),
        )
        _run(rec, root / "pitch" / scenario, CONFIG.with_overrides({"camera": str(wrong)}))
    return {name: root / name for name in ("base", "v1", "pitch")}


def test_a_weaker_model_is_worse(fleets: dict[str, Path], tmp_path: Path) -> None:
    result = compare_runs(fleets["base"], fleets["v1"], tmp_path, QUICK)
    fleet = result.comparison.fleet_rows().set_index("kpi")
    assert fleet.at["availability_frames.super", "delta"] < 0, fleet["delta"]
    assert fleet.at["availability_frames.super", "verdict"] == TOO_FEW
    assert fleet.at["availability_frames.super", "n_drives"] == 2
    assert "onnx:super_seg_v1" in set(result.differences["key"])


def test_a_wrong_camera_pitch_is_worse(fleets: dict[str, Path], tmp_path: Path) -> None:
    result = compare_runs(fleets["base"], fleets["pitch"], tmp_path, QUICK)
    fleet = result.comparison.fleet_rows().set_index("kpi")
    assert fleet.at["lane_width_bias", "delta"] > 0, fleet["delta"]
    assert fleet.at["availability_frames.mobileye", "delta"] == 0.0  # CAN: untouched
    pitch = result.differences.set_index("key")
    assert pitch.at["resolved.camera.extrinsics.pitch_rad", "candidate"] == "0.1"


def test_a_run_without_truth_has_no_truth_kpis(oracle_runs: Any, tmp_path: Path) -> None:
    from typer.testing import CliRunner

    from superlane_tools.cli.app import app

    src, dst = oracle_runs.recording, tmp_path / "no_gnss.mcap"
    cut = CliRunner().invoke(app, ["filter", str(src), "--exclude", "^/gnss/fix$", "-o", str(dst)])
    assert cut.exit_code == 0, cut.output  # the drive without its RTK topic
    config = ReprocessConfig().with_overrides(
        {
            "segmentation.backend": "oracle",
            "segmentation.oracle_labels": str(src.parent / "curves_labels" / "labels"),
            "kpi.window_s": 0.25,
            "output.plots": False,
            "output.example_frames": 0,
        }
    )
    _run(dst, tmp_path / "no_truth" / "curves", config)
    result = compare_runs(oracle_runs.base.parent, tmp_path / "no_truth", tmp_path / "out", QUICK)
    fleet = result.comparison.fleet_rows().set_index("kpi")
    truth = fleet.loc[fleet.index.str.startswith("curvature_rmse_truth")]
    assert (truth["verdict"] == UNPAIRED).all(), truth  # another recording: no matched drive
    assert all(math.isnan(v) for v in truth["candidate"])  # unavailable, never 0
    assert "no drive matched" in (tmp_path / "out" / "compare.md").read_text()
