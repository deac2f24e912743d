"""`slt segment` and `slt corridor` read a recording's camera frames as well as image folders."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest
from typer.testing import CliRunner

from superlane_tools.cli.app import app

runner = CliRunner()


@pytest.fixture(scope="module")
def drive(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("rec") / "d.mcap"
    args = ["simulate", "--scenario", "highway_straight", "--duration", "1", "--seed", "2"]
    res = runner.invoke(app, [*args, "--width", "320", "--height", "180", "--out", str(path)])
    assert res.exit_code == 0, res.output
    return path


def test_segment_a_recording(drive: Path, tmp_path: Path) -> None:
    out = tmp_path / "seg"
    res = runner.invoke(app, ["segment", str(drive), "--out", str(out)])
    assert res.exit_code == 0, res.output
    labels = sorted((out / "camera_image_compressed").glob("*.png"))
    assert [p.name for p in labels[:2]] == ["000000.png", "000001.png"]
    assert len(labels) == 15
    assert (out / "classes.yaml").is_file()


def test_corridor_on_a_truncated_recording_is_partial(tmp_path: Path) -> None:
    sample = Path(__file__).resolve().parents[2] / "fixtures" / "sample_drive.mcap"
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(sample.read_bytes()[:2_000_000])  # the first chunks of 240 frames
    out = tmp_path / "cor"
    res = runner.invoke(app, ["corridor", str(cut), "--out", str(out)])
    assert res.exit_code == 3, res.output
    assert "truncated" in res.output
    table = pd.read_parquet(out / "corridor.parquet")
    assert 0 < len(table) < 240
    assert table["name"].iloc[0] == "camera_image_compressed/000000.png"


def test_not_a_recording(tmp_path: Path) -> None:
    bogus = tmp_path / "x.mcap"
    bogus.write_bytes(b"nope")
    res = runner.invoke(app, ["segment", str(bogus), "--out", str(tmp_path / "o")])
    assert res.exit_code == 1
    assert "not a recording" in res.output
