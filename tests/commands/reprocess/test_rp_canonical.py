"""``slt reprocess --canonical-camera`` end to end on a short simulated drive (real MCAP)."""

from __future__ import annotations

import ast
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from superlane_tools.cli.app import app
from superlane_tools.recording import open_recording
from superlane_tools.reporting import read_provenance
from superlane_tools.reporting.layout import RunLayout
from superlane_tools.simulation.drive import simulate_drive

WIDTH, HEIGHT = 320, 180


@pytest.fixture(scope="module")
def drive(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("drive") / "canon.mcap"
    simulate_drive("highway_curves", 2.0, 5, "mcap", WIDTH, HEIGHT, False, out)
    return out


def _reprocess(drive: Path, out: Path, *flags: str) -> Path:
    args = ["reprocess", str(drive), "-o", str(out), "--backend", "onnx", "--no-plots", *flags]
    result = CliRunner().invoke(app, args, catch_exceptions=False)
    assert result.exit_code == 0, result.output
    return out


@pytest.fixture(scope="module")
def runs(drive: Path, tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    root = tmp_path_factory.mktemp("runs")
    return (
        _reprocess(drive, root / "canon", "--canonical-camera"),
        _reprocess(drive, root / "plain", "--no-canonical-camera"),
    )


def _config(layout: RunLayout) -> dict[str, Any]:
    config = read_provenance(layout.lanes)["config"]
    return config if isinstance(config, dict) else ast.literal_eval(config)


def _ego_offsets(lanes: pd.DataFrame) -> np.ndarray:
    rows = lanes[(lanes["ego_left"] >= 0) & (lanes["ego_right"] >= 0)]
    return np.array([[r.offsets[r.ego_left], r.offsets[r.ego_right]] for r in rows.itertuples()])


def _annotation_rows(path: Path) -> list[float]:
    ys: list[float] = []
    with open_recording(path) as rec:
        for msg in rec.messages(topics=["/slt/annotations"]):
            for ann in msg.data.points:
                ys += [p.y for p in ann.points]
    return ys


def test_reprocess_with_the_canonical_camera_writes_outputs_in_recording_pixels(
    runs: tuple[Path, Path],
) -> None:
    canon, plain = (RunLayout(p) for p in runs)
    config = _config(canon)
    assert str(config["resolved"]["segmentation_backend"]).endswith("+canonical")
    assert config["segmentation"]["canonical_camera"] is True
    assert "segmentation backend: onnx:" in canon.report.read_text(encoding="utf-8")
    lanes, lanes_plain = pd.read_parquet(canon.lanes), pd.read_parquet(plain.lanes)
    assert len(lanes) == len(lanes_plain) == 30
    assert set(lanes["width"]) == {WIDTH}
    assert set(lanes["height"]) == {HEIGHT}
    # the network finds the ego lane through the canonical camera, at the same place in metres
    # as without it: its labels came back to the recording's pixels
    ego, ego_plain = _ego_offsets(lanes), _ego_offsets(lanes_plain)
    assert len(ego) >= 15
    assert len(ego_plain) >= 15
    assert np.median(ego[:, 0]) > 1.0
    assert np.median(ego[:, 1]) < -1.0
    np.testing.assert_allclose(np.median(ego, axis=0), np.median(ego_plain, axis=0), atol=0.3)
    ys, ys_plain = _annotation_rows(canon.annotations), _annotation_rows(plain.annotations)
    assert ys
    assert ys_plain
    assert 0 < np.median(ys) < HEIGHT
    assert abs(np.median(ys) - np.median(ys_plain)) < 10.0


def test_no_canonical_camera_is_the_default(runs: tuple[Path, Path]) -> None:
    config = _config(RunLayout(runs[1]))
    assert config["segmentation"]["canonical_camera"] is False
    assert not str(config["resolved"]["segmentation_backend"]).endswith("+canonical")
    from superlane_tools.drive.config import ReprocessConfig

    assert ReprocessConfig().segmentation.canonical_camera is False
