"""Heterogeneous training: per-dataset head masking, augmentation geometry, the train CLI."""

from __future__ import annotations

from pathlib import Path

import pytest
import torch
from typer.testing import CliRunner

from superlane_tools.cli.app import app
from superlane_tools.scene.adapters.heads import HEADS, IGNORE, NODE_CODES, head_target_lut
from superlane_tools.scene.model_card import load_card
from superlane_tools.training.augment import RealAugment, affine_theta, warp
from superlane_tools.training.loop import HEAD_WEIGHTS, head_targets_masked
from superlane_tools.training.losses import segmentation_loss
from superlane_tools.training.seg_net import HierarchicalSegNet

DRIVABLE = [h.name for h in HEADS].index("head_drivable")


def _drivable_grad(codes: torch.Tensor, heads: torch.Tensor) -> torch.Tensor:
    torch.manual_seed(0)
    net = HierarchicalSegNet()
    x = torch.randn(codes.shape[0], 3, *codes.shape[1:])
    luts = [torch.from_numpy(head_target_lut(h)) for h in HEADS]
    targets = head_targets_masked(codes, heads, luts)
    loss = segmentation_loss(net(x), targets, HEAD_WEIGHTS, marking_dice=1.0, dice_bands=2)
    loss.backward()  # type: ignore[no-untyped-call]
    start = sum(len(h.classes) for h in HEADS[:DRIVABLE])
    grad = net.classifier.weight.grad
    assert grad is not None
    return grad[start : start + len(HEADS[DRIVABLE].classes)]


def test_dataset_without_a_level_gives_that_head_zero_gradient() -> None:
    codes = torch.full((2, 32, 48), NODE_CODES["road"], dtype=torch.int64)
    codes[:, :, 20:24] = NODE_CODES["lane_marking"]
    codes[:, :8] = NODE_CODES["sky"]
    every = torch.ones(2, len(HEADS), dtype=torch.bool)
    coarse = every.clone()
    coarse[:, DRIVABLE:] = False  # a dataset that labels levels 1 and 2 only
    assert float(_drivable_grad(codes, every).abs().sum()) > 0
    assert float(_drivable_grad(codes, coarse).abs().sum()) == 0.0


def test_masked_targets_are_ignore_for_masked_frames_only() -> None:
    codes = torch.full((2, 4, 4), NODE_CODES["road"], dtype=torch.int64)
    heads = torch.tensor([[True] * len(HEADS), [True, True, True, False, False]])
    luts = [torch.from_numpy(head_target_lut(h)) for h in HEADS]
    targets = head_targets_masked(codes, heads, luts)
    assert bool((targets[DRIVABLE][1] == IGNORE).all())
    assert not bool((targets[DRIVABLE][0] == IGNORE).any())


def test_identity_warp_keeps_image_and_labels() -> None:
    gen = torch.Generator().manual_seed(0)
    image = torch.rand(3, 36, 64)
    target = torch.randint(0, 20, (36, 64))
    theta = affine_theta((64, 36), (64, 36), None, gen, random_crop=False)
    warped, labels = warp(image, target, theta, (64, 36), outside=0)
    assert torch.allclose(warped, image, atol=1e-5)
    assert torch.equal(labels, target)


def test_augmented_warp_marks_outside_pixels_unknown() -> None:
    gen = torch.Generator().manual_seed(3)
    params = RealAugment(scale=(0.6, 0.6), roll_deg=0.0, pitch_frac=0.0, flip_prob=0.0)
    theta = affine_theta((64, 36), (64, 36), params, gen, random_crop=False)
    _, labels = warp(torch.rand(1, 36, 64), torch.ones(36, 64, dtype=torch.int64), theta,
                     (64, 36), outside=255)  # fmt: skip
    assert labels[18, 32] == 1
    assert labels[0, 0] == 255


def test_train_cli_tiny_heterogeneous_run(realdata: Path, toy_data: Path, tmp_path: Path) -> None:
    out = tmp_path / "seg.onnx"
    result = CliRunner().invoke(
        app,
        [
            "train", "segmentation",
            "--data", f"tusimple={realdata / 'tusimple' / 'train_frames'}",
            "--data", f"camvid:0.5={realdata / 'camvid'}",
            "--data", f"sim={toy_data}",
            "--out", str(out), "--steps", "2", "--batch", "2", "--size", "64x36",
            "--crop", "48x32", "--max-frames", "2", "--threads", "1", "--dice-bands", "2",
        ],
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    card = load_card(tmp_path / "seg.card.yaml")
    rows = {row["reader"]: row for row in card.training["datasets"]}
    assert set(rows) == {"tusimple", "camvid", "sim"}
    assert "CC BY-NC 4.0" in rows["camvid"]["licence"]
    assert card.training["steps"] == 2


@pytest.mark.parametrize("bad", ["camvid:-1=/x", "nowhere=/does/not/exist"])
def test_train_cli_bad_data_is_a_one_line_error(bad: str, tmp_path: Path) -> None:
    result = CliRunner().invoke(
        app, ["train", "segmentation", "--data", bad, "--out", str(tmp_path / "m.onnx")]
    )
    assert result.exit_code in (1, 2)
    assert "Traceback" not in result.output


def test_shipped_cards_match_their_model_files() -> None:
    from superlane_tools.reporting.provenance import file_sha256

    models = Path(__file__).resolve().parents[2] / "superlane_tools" / "models"
    cards = sorted(models.glob("*.card.yaml"))
    assert cards
    for card_path in cards:
        card = load_card(card_path)
        onnx = models / card_path.name.replace(".card.yaml", ".onnx")
        assert card.sha256 == file_sha256(onnx), onnx.name
