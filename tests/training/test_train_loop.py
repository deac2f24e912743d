"""Training loop, export and card: a tiny model trains and exports; onnxruntime matches torch."""

from __future__ import annotations

import sys
from collections.abc import Callable
from pathlib import Path

import numpy as np
import onnxruntime as ort
import pytest
import torch

from superlane_tools.reporting import file_sha256
from superlane_tools.scene.model_card import load_card
from superlane_tools.training import TrainingError, require_torch
from superlane_tools.training._blocks import count_parameters
from superlane_tools.training.corridor_net import EgoCorridorNet
from superlane_tools.training.export import export_onnx
from superlane_tools.training.seg_net import HierarchicalSegNet
from superlane_tools.training.train import TrainParams, TrainResult, train


@pytest.mark.slow
def test_loss_decreases_over_one_epoch(tiny_seg: TrainResult, tiny_corridor: TrainResult) -> None:
    for result in (tiny_seg, tiny_corridor):
        assert len(result.step_losses) == 4
        assert result.step_losses[-1] < result.step_losses[0]
        assert len(result.epoch_losses) == 1


@pytest.mark.slow
def test_same_seed_same_run(
    toy_data: Path,
    tiny_corridor: TrainResult,
    tiny_params: Callable[[str, Path, Path], TrainParams],
    tmp_path: Path,
) -> None:
    again = train(tiny_params("corridor", toy_data, tmp_path / "again.onnx"))
    assert again.step_losses == tiny_corridor.step_losses
    assert again.card.sha256 == tiny_corridor.card.sha256


@pytest.mark.slow
@pytest.mark.parametrize("net", ["segmentation", "corridor"])
def test_onnxruntime_agrees_with_torch(net: str, tmp_path: Path) -> None:
    torch.manual_seed(0)
    model = HierarchicalSegNet() if net == "segmentation" else EgoCorridorNet()
    shape = (1, 3, 96, 160) if net == "segmentation" else (1, 1, 90, 163)
    names = [f"out{i}" for i in range(5 if net == "segmentation" else 1)]
    export_onnx(model, shape, tmp_path / "m.onnx", "image", names)
    x = torch.randn(*shape, generator=torch.Generator().manual_seed(1))
    with torch.no_grad():
        ref = model(x)
    refs = ref if isinstance(ref, tuple) else (ref,)
    session = ort.InferenceSession(str(tmp_path / "m.onnx"), providers=["CPUExecutionProvider"])
    got = session.run(names, {"image": x.numpy()})
    for a, b in zip(got, refs, strict=True):
        assert a.shape == tuple(b.shape)
        assert np.abs(a - b.numpy()).max() < 1e-4


def test_parameter_budgets() -> None:
    seg = count_parameters(HierarchicalSegNet())
    corridor = count_parameters(EgoCorridorNet())
    assert 300_000 <= seg <= 1_000_000
    assert corridor < 1_000_000


def test_card_is_written_beside_the_model(
    tiny_seg: TrainResult, tiny_corridor: TrainResult
) -> None:
    for result, task in ((tiny_seg, "segmentation"), (tiny_corridor, "corridor")):
        assert result.card_path == result.model_path.with_name(
            result.model_path.name.removesuffix(".onnx") + ".card.yaml"
        )
        card = load_card(result.card_path)
        assert card.task == task
        assert card.sha256 == file_sha256(result.model_path)
        assert (card.input.width, card.input.height) == (64, 32)
        assert card.training["seed"] == 0
        assert card.training["onnx_vs_torch_max_abs_diff"] < 1e-4
    assert load_card(tiny_seg.card_path).input.color_order == "RGB"
    assert load_card(tiny_corridor.card_path).input.color_order == "GRAY"


def test_missing_dataset_is_a_training_error(tmp_path: Path) -> None:
    with pytest.raises(TrainingError, match=r"no index\.parquet"):
        train(TrainParams("corridor", tmp_path, tmp_path / "m.onnx"))
    with pytest.raises(TrainingError, match="unknown task"):
        train(TrainParams("detection", tmp_path, tmp_path / "m.onnx"))


def test_missing_torch_names_the_extra(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "torch", None)
    with pytest.raises(TrainingError, match=r"superlane-tools\[train\]"):
        require_torch()


def test_exported_half_resolution_heads_upsample_to_the_training_forward(tmp_path: Path) -> None:
    from superlane_tools.scene.model_card import InputSpec
    from superlane_tools.scene.onnx_backend import upsample_scores
    from superlane_tools.training.seg_net import HalfResolutionHeads

    torch.manual_seed(0)
    net = HierarchicalSegNet().eval()
    names = [f"out{i}" for i in range(5)]
    export_onnx(HalfResolutionHeads(net), (1, 3, 96, 160), tmp_path / "m.onnx", "image", names)
    x = torch.randn(1, 3, 96, 160, generator=torch.Generator().manual_seed(1))
    with torch.no_grad():
        ref = net(x)  # what training optimises: logits at the input size
    session = ort.InferenceSession(str(tmp_path / "m.onnx"), providers=["CPUExecutionProvider"])
    got = upsample_scores(session.run(names, {"image": x.numpy()}), InputSpec("image", 160, 96))
    for a, b in zip(got, ref, strict=True):
        assert a.shape == tuple(b.shape[1:])
        assert np.abs(a - b[0].numpy()).max() < 1e-4
