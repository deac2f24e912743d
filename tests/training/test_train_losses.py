"""Losses for thin structures: lane-marking Dice down the tree, corridor BCE + Dice, data concat."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
import torch

from superlane_tools.scene.adapters.heads import HEADS, IGNORE, NODE_CODES, head_target_lut
from superlane_tools.scene.model_card import load_card
from superlane_tools.training.corridor_net import CorridorNetConfig, EgoCorridorNet
from superlane_tools.training.losses import (
    corridor_loss,
    hierarchical_loss,
    marking_probability,
    marking_targets,
    segmentation_loss,
    soft_dice_loss,
)
from superlane_tools.training.train import TrainParams, train


def _targets(codes: np.ndarray) -> list[torch.Tensor]:
    return [torch.from_numpy(head_target_lut(h)[codes]) for h in HEADS]


def _codes() -> np.ndarray:
    """A 1x4x4 node-code image: sky row, road row, marking row, 'drivable, finer unknown' row."""
    rows = ["sky", "road", "dividing_white_dashed", "drivable"]
    return np.array([[[NODE_CODES[name]] * 4 for name in rows]], dtype=np.uint8)


def test_marking_targets_know_only_labelled_levels() -> None:
    target, known = marking_targets(_targets(_codes()))
    assert target[0, 2].tolist() == [1.0] * 4  # the marking row
    assert target[0, :2].sum() == 0
    assert known[0, :3].all()
    assert not known[0, 3].any()  # Cityscapes-style 'drivable': its markings are unknown


def test_marking_probability_is_the_product_down_the_tree() -> None:
    logits = [torch.zeros(1, len(h.classes), 2, 2) for h in HEADS]
    p = marking_probability(logits)
    expected = (1 / 3) * (1 / 3) * (1 / 5)  # uniform root, support and drivable heads
    assert torch.allclose(p, torch.full((1, 2, 2), expected))


def test_soft_dice_is_zero_for_a_perfect_mask_and_one_for_a_disjoint_one() -> None:
    target = torch.zeros(1, 8, 8)
    target[:, 2:4] = 1.0
    assert float(soft_dice_loss(target, target)) == pytest.approx(0.0, abs=1e-6)
    assert float(soft_dice_loss(1.0 - target, target)) > 0.95
    valid = torch.zeros(1, 8, 8, dtype=torch.bool)
    valid[:, 2:4] = True
    assert float(soft_dice_loss(torch.ones(1, 8, 8), target, valid)) == pytest.approx(0.0, abs=1e-6)


def test_dice_term_rewards_predicting_the_markings() -> None:
    codes = _codes()
    targets = _targets(codes)
    logits = [torch.zeros(1, len(h.classes), 4, 4) for h in HEADS]
    base = float(hierarchical_loss(logits, targets, (1.0,) * 5))
    with_dice = float(segmentation_loss(logits, targets, (1.0,) * 5, marking_dice=1.0))
    assert with_dice > base
    good = [t.clone() for t in logits]
    marking_row = torch.zeros(4, 4, dtype=torch.bool)
    marking_row[2] = True
    good[0][0, 2, marking_row] = 10.0  # support
    good[2][0, 2, marking_row] = 10.0  # drivable
    good[3][0, 3, marking_row] = 10.0  # lane_marking
    dice_good = float(segmentation_loss(good, targets, (0.0,) * 5, marking_dice=1.0))
    dice_flat = float(segmentation_loss(logits, targets, (0.0,) * 5, marking_dice=1.0))
    assert dice_good < 0.2 < dice_flat


def test_corridor_dice_adds_to_bce() -> None:
    target = torch.zeros(1, 1, 6, 6)
    target[..., 3:, 2:4] = 1.0
    logits = torch.zeros(1, 1, 6, 6)
    assert float(corridor_loss(logits, target, dice=1.0)) > float(corridor_loss(logits, target))
    assert IGNORE < 0  # the Dice path never sees ignore labels: corridor targets are binary


def test_corridor_net_sees_horizontal_position() -> None:
    torch.manual_seed(0)
    flat = torch.zeros(1, 1, 64, 128)
    with torch.no_grad():
        with_coords = EgoCorridorNet(CorridorNetConfig(coords=True)).eval()(flat)
        without = EgoCorridorNet(CorridorNetConfig(coords=False)).eval()(flat)
    # the centre of the frame, away from the zero padding at the borders
    spread_without = float(without[0, 0, 32, 48:80].max() - without[0, 0, 32, 48:80].min())
    spread_with = float(with_coords[0, 0, 32, 48:80].max() - with_coords[0, 0, 32, 48:80].min())
    assert spread_without < 1e-7  # a constant image: no way to tell left from right
    assert spread_with > 1e-6  # untrained, so small, but position-dependent
    assert with_coords.shape == flat.shape


def test_extra_data_folders_are_concatenated(
    toy_data: Path, tiny_params: Callable[[str, Path, Path], TrainParams], tmp_path: Path
) -> None:
    base = tiny_params("corridor", toy_data, tmp_path / "m.onnx")
    params = TrainParams(
        base.task,
        base.data_dir,
        base.out,
        extra_data=(toy_data,),
        epochs=1,
        batch=4,
        size=base.size,
        augment=None,
    )
    result = train(params)
    card = load_card(result.card_path)
    assert card.training["frames"] == 16
    assert len(card.training["data"]) == 2
    assert len(result.step_losses) == 4
