"""Fixtures of the training tests: a toy dataset and tiny trained models (built once)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import pytest

from superlane_tools.training.toy_dataset import write_toy_dataset
from superlane_tools.training.train import TrainParams, TrainResult, train


def _tiny_params(task: str, data: Path, out: Path) -> TrainParams:
    """One epoch of 4 steps on the 8 toy frames at 64x32, no augmentation, seed 0."""
    return TrainParams(task, data, out, epochs=1, batch=2, lr=5e-3, size=(64, 32), augment=None)


@pytest.fixture(scope="session")
def tiny_params() -> Callable[[str, Path, Path], TrainParams]:
    return _tiny_params


@pytest.fixture(scope="session")
def toy_data(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_toy_dataset(tmp_path_factory.mktemp("toy"), frames=8, width=128, height=64)


@pytest.fixture(scope="session")
def tiny_seg(toy_data: Path, tmp_path_factory: pytest.TempPathFactory) -> TrainResult:
    out = tmp_path_factory.mktemp("seg") / "tiny_seg.onnx"
    return train(_tiny_params("segmentation", toy_data, out))


@pytest.fixture(scope="session")
def tiny_corridor(toy_data: Path, tmp_path_factory: pytest.TempPathFactory) -> TrainResult:
    out = tmp_path_factory.mktemp("cor") / "tiny_corridor.onnx"
    return train(_tiny_params("corridor", toy_data, out))
