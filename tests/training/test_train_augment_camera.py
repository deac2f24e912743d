"""Camera-geometry and photometric augmentation on a labelled real TuSimple frame.

Every geometric transform is checked the same way: after the warp, the pixels labelled lane
marking must still be the bright paint of the image (their mean brightness well above the road
pixels'), and a label shifted by a few pixels must fail that check (so the test can fail).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import torch
import torch.nn.functional as F  # noqa: N812  (torch convention)

from superlane_tools.scene.adapters.heads import HEADS, NODE_CODES, head_target_lut
from superlane_tools.training.augment import (
    CAMERA_AUGMENT,
    MIRROR_SWAP,
    RealAugment,
    affine_theta,
    is_mirrored,
    mirror_swap_table,
    night,
    photometric,
    warp,
)
from superlane_tools.training.datasets import DatasetSpec, load_set

DRIVABLE = next(h for h in HEADS if h.name == "head_drivable")
MARKING = DRIVABLE.classes.index("lane_marking")
OFF = RealAugment(
    scale=(1.0, 1.0), roll_deg=0.0, pitch_frac=0.0, flip_prob=0.0, brightness=0.0, contrast=0.0,
    channel_gain=0.0, gamma=0.0, shadow_prob=0.0, blur_prob=0.0, jpeg_prob=0.0, noise_std=0.0,
)  # fmt: skip
"""Every part switched off; each test switches one on."""
GEOMETRY = {
    "zoom_in (longer focal length)": RealAugment(**{**OFF.__dict__, "scale": (1.4, 1.4)}),
    "zoom_out (shorter focal length)": RealAugment(**{**OFF.__dict__, "scale": (0.7, 0.7)}),
    "aspect": RealAugment(**{**OFF.__dict__, "aspect": (0.75, 0.76)}),
    "roll": RealAugment(**{**OFF.__dict__, "roll_deg": 4.0}),
    "pitch (horizon shift)": RealAugment(**{**OFF.__dict__, "pitch_frac": 0.08}),
    "mirror": RealAugment(**{**OFF.__dict__, "flip_prob": 1.0}),
    "everything (camera recipe)": CAMERA_AUGMENT,
}


@pytest.fixture(scope="module")
def frame(realdata: Path) -> tuple[torch.Tensor, torch.Tensor]:
    """A real TuSimple frame at 512x288 ([0, 1] RGB) and its node-code label."""
    spec = DatasetSpec("tusimple", realdata / "tusimple" / "train_frames", split="val")
    loaded = load_set(spec, "segmentation", (512, 288), max_frames=1)
    assert loaded.codes is not None
    image = torch.from_numpy(np.ascontiguousarray(loaded.images[0][..., ::-1])).permute(2, 0, 1)
    return image.float() / 255.0, torch.from_numpy(loaded.codes[0]).long()


def _paint_contrast(image: torch.Tensor, codes: torch.Tensor) -> float:
    """Mean local contrast (gray minus its 25-px row mean) of the label's marking pixels.

    Paint is brighter than the asphalt beside it, whatever the lighting of the frame.
    """
    classes = torch.from_numpy(head_target_lut(DRIVABLE)).long()[codes.clamp(0, 255)]
    gray = image.mean(dim=0)[None, None]
    local = F.avg_pool2d(F.pad(gray, (12, 12, 0, 0), mode="replicate"), (1, 25), 1)
    marking = classes == MARKING
    assert int(marking.sum()) > 200, "too few marking pixels left to judge"
    return float((gray - local)[0, 0][marking].mean())


def test_the_frame_is_labelled_and_a_shifted_label_fails_the_check(
    frame: tuple[torch.Tensor, torch.Tensor],
) -> None:
    image, codes = frame
    aligned = _paint_contrast(image, codes)
    assert aligned > 0.02
    assert max(_paint_contrast(image, torch.roll(codes, d, dims=1)) for d in (-12, 12)) < 0.0


def _marking_iou(mask: torch.Tensor, codes: torch.Tensor) -> float:
    classes = torch.from_numpy(head_target_lut(DRIVABLE)).long()[codes.clamp(0, 255)]
    label = classes == MARKING
    return float((label & mask).sum() / (label | mask).sum())


@pytest.mark.parametrize("name", list(GEOMETRY))
def test_geometric_transform_keeps_labels_on_the_paint(
    frame: tuple[torch.Tensor, torch.Tensor], name: str
) -> None:
    image, codes = frame
    before = _paint_contrast(image, codes)
    classes = torch.from_numpy(head_target_lut(DRIVABLE)).long()[codes]
    marking = (classes == MARKING).float()[None]
    for seed in range(3):
        gen = torch.Generator().manual_seed(seed)
        theta = affine_theta((512, 288), (320, 192), GEOMETRY[name], gen, random_crop=True)
        warped, labels = warp(torch.cat([image, marking]), codes, theta, (320, 192), 0, MIRROR_SWAP)
        if "mirror" in name:
            assert is_mirrored(theta)
        # the label matches the marking mask resampled as an image channel (a shifted one not)
        mask = warped[3] > 0.5
        assert _marking_iou(mask, labels) > 0.75, name
        assert _marking_iou(mask, torch.roll(labels, 6, dims=1)) < 0.5, name
        # the paint of the whole frame stays under the label (centred, input size)
        theta = affine_theta((512, 288), (512, 288), GEOMETRY[name], gen, random_crop=False)
        warped, labels = warp(image, codes, theta, (512, 288), 0, MIRROR_SWAP)
        after = _paint_contrast(warped, labels)
        assert after > 0.5 * before, f"{name}, seed {seed}: {after:.3f} vs {before:.3f}"
        shifted = (_paint_contrast(warped, torch.roll(labels, d, dims=1)) for d in (-12, 12))
        assert max(shifted) < after / 2


def test_mirror_of_the_whole_frame_is_the_flipped_label(
    frame: tuple[torch.Tensor, torch.Tensor],
) -> None:
    image, codes = frame
    theta = torch.tensor([[-1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    warped, labels = warp(image, codes, theta, (512, 288), 0, MIRROR_SWAP)
    assert torch.equal(labels, torch.flip(codes, dims=[1]))
    assert torch.allclose(warped, torch.flip(image, dims=[2]), atol=1e-5)


def test_mirror_swaps_left_and_right_classes_only() -> None:
    table = mirror_swap_table({1: "arrow_left", 2: "arrow_right", 3: "road", 4: "left_only"})
    assert (int(table[1]), int(table[2]), int(table[3]), int(table[4])) == (2, 1, 3, 4)
    # today's hierarchy has no side-dependent class: marking type and colour keep their code
    assert np.array_equal(MIRROR_SWAP, np.arange(256, dtype=np.uint8))
    assert all("left" not in n and "right" not in n for n in NODE_CODES)


def test_photometric_transforms_keep_the_paint_visible(
    frame: tuple[torch.Tensor, torch.Tensor],
) -> None:
    image, codes = frame
    batch = image[None].repeat(4, 1, 1, 1)
    gen = torch.Generator().manual_seed(0)
    for field, value in (
        ("brightness", 0.35), ("contrast", 0.35), ("temperature", 0.12), ("gamma", 0.3),
        ("shadow_prob", 1.0), ("blur_prob", 1.0), ("night_prob", 1.0), ("noise_std", 0.03),
    ):  # fmt: skip
        out = photometric(batch, RealAugment(**{**OFF.__dict__, field: value}), gen)
        assert out.shape == batch.shape
        assert float(out.min()) >= 0.0
        assert float(out.max()) <= 1.0
        assert not torch.equal(out, batch), field
        for frame_out in out:
            assert _paint_contrast(frame_out, codes) > 0.005, field


def test_colour_temperature_moves_red_against_blue(
    frame: tuple[torch.Tensor, torch.Tensor],
) -> None:
    image, _ = frame
    gen = torch.Generator().manual_seed(3)
    out = photometric(
        image[None].repeat(8, 1, 1, 1), RealAugment(**{**OFF.__dict__, "temperature": 0.2}), gen
    )
    ratio = (out[:, 0].mean(dim=(1, 2)) / out[:, 2].mean(dim=(1, 2))) / float(
        image[0].mean() / image[2].mean()
    )
    assert float(ratio.max()) > 1.05
    assert float(ratio.min()) < 0.95


def test_night_darkens_the_frame_and_tints_it_blue(
    frame: tuple[torch.Tensor, torch.Tensor],
) -> None:
    image, codes = frame
    gen = torch.Generator().manual_seed(0)
    dusk, dark = night(image, 0.0, gen), night(image, 1.0, gen)
    assert float(image.mean()) > float(dusk.mean()) > float(dark.mean())
    assert float(dark[2].mean() / dark[0].mean()) > float(image[2].mean() / image[0].mean())
    assert _paint_contrast(dark, codes) > 0.0
