"""`slt corridor` and `slt train` through typer's CliRunner on apps built with `register`."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pandas as pd
import pytest
import typer
from typer.testing import CliRunner

from superlane_tools.cli import corridor as corridor_cli
from superlane_tools.cli import train as train_cli
from superlane_tools.reporting import read_provenance
from superlane_tools.reporting.layout import CORRIDOR_MASKS_TABLE, checked_table
from superlane_tools.training.toy_dataset import toy_frame, write_toy_dataset

runner = CliRunner()


def _app(module: object) -> typer.Typer:
    app = typer.Typer()
    module.register(app)  # type: ignore[attr-defined]

    @app.callback()
    def _root() -> None:
        """Test root."""

    return app


@pytest.fixture(scope="module")
def corridor_model(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("cli")
    data = write_toy_dataset(root / "data", frames=2, width=96, height=48)
    more = write_toy_dataset(root / "more", frames=2, width=96, height=48, seed=5)
    out = root / "cor.onnx"
    args = ["train", "corridor", "--data", str(data), "--data", str(more), "--out", str(out)]
    result = runner.invoke(_app(train_cli), [*args, "--epochs", "1", "--size", "64x32"])
    assert result.exit_code == 0, result.output
    card = (root / "cor.card.yaml").read_text()
    assert str(data) in card
    assert str(more) in card  # repeated --data folders are concatenated
    return out


@pytest.mark.slow
def test_corridor_cli_writes_maps_and_parquet(corridor_model: Path, tmp_path: Path) -> None:
    images = tmp_path / "images"
    images.mkdir()
    rng = np.random.default_rng(2)
    for i in range(3):
        cv2.imwrite(str(images / f"{i:03d}.png"), toy_frame(rng, 160, 90)[0])
    (images / "broken.png").write_bytes(b"not a png")
    out = tmp_path / "out"
    args = ["corridor", str(images), "--out", str(out), "--model", str(corridor_model)]
    result = runner.invoke(_app(corridor_cli), [*args, "--camera", "sim_default"])
    assert result.exit_code == 3, result.output  # partial: the broken image was skipped
    assert "broken.png" in result.output
    maps = sorted(out.glob("*.png"))
    assert [p.name for p in maps] == ["000.png", "001.png", "002.png"]
    prob = cv2.imread(str(maps[0]), cv2.IMREAD_UNCHANGED)
    assert prob.shape == (90, 160)
    assert prob.dtype == np.uint8
    table = pd.read_parquet(out / "corridor.parquet")
    checked_table(CORRIDOR_MASKS_TABLE, table)  # the declared schema
    assert list(table.columns) == ["name", "corridor_fraction", "width_m", "length_m"]
    assert len(table) == 3
    assert "cor" in read_provenance(out / "corridor.parquet")["models"]


def test_corridor_cli_refuses_a_bad_model(tmp_path: Path) -> None:
    (tmp_path / "in").mkdir()
    bad = tmp_path / "m.onnx"
    bad.write_bytes(b"junk")
    args = ["corridor", str(tmp_path / "in"), "--out", str(tmp_path / "o"), "--model", str(bad)]
    result = runner.invoke(_app(corridor_cli), args)
    assert result.exit_code == 1
    assert "model card not found" in result.output


def test_train_cli_usage_errors(tmp_path: Path) -> None:
    app = _app(train_cli)
    result = runner.invoke(app, ["train", "detection", "--data", ".", "--out", "m.onnx"])
    assert result.exit_code == 2
    assert "TASK must be one of" in result.output
    args = ["train", "corridor", "--data", str(tmp_path), "--out", str(tmp_path / "m.onnx")]
    result = runner.invoke(app, [*args, "--size", "64by32"])
    assert result.exit_code == 2
    result = runner.invoke(app, args)
    assert result.exit_code == 1
    assert "no index.parquet" in result.output
