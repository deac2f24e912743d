"""Fixtures of the training tests: a toy dataset and tiny trained models (built once)."""

from __future__ import annotations

from pathlib import Path

import pytest

from superlane_tools.training.toy_dataset import write_toy_dataset
from superlane_tools.training.train import TrainParams, TrainResult, train


@pytest.fixture(scope="session")
def toy_data(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_toy_dataset(tmp_path_factory.mktemp("toy"), frames=8, width=128, height=64)


@pytest.fixture(scope="session")
def tiny_seg(toy_data: Path, tmp_path_factory: pytest.TempPathFactory) -> TrainResult:
    out = tmp_path_factory.mktemp("seg") / "tiny_seg.onnx"
    return train(
        TrainParams("segmentation", toy_data, out, epochs=1, batch=2, size=(64, 32), max_frames=4)
    )


@pytest.fixture(scope="session")
def tiny_corridor(toy_data: Path, tmp_path_factory: pytest.TempPathFactory) -> TrainResult:
    out = tmp_path_factory.mktemp("cor") / "tiny_corridor.onnx"
    return train(
        TrainParams("corridor", toy_data, out, epochs=1, batch=2, size=(64, 32), max_frames=4)
    )
