"""Training data: read a ``slt simulate dataset`` folder into memory, and augment batches in torch.

A dataset folder holds ``index.parquet`` with one row per frame and relative-path columns
``image`` (BGR colour image), ``labels`` (label image in the dataset's ids; leaf ids for the
simulator) and ``corridor`` (ego-corridor mask, non-zero = corridor). Frames are resized to the
training size once, on load (images with area interpolation, labels nearest-neighbour).
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
import torch
import torch.nn.functional as F  # noqa: N812  (torch convention)
from numpy.typing import NDArray

from superlane_tools.reporting.layout import DATASET_INDEX_TABLE
from superlane_tools.scene.adapters.loader import DatasetAdapter
from superlane_tools.training.errors import TrainingError

INDEX_NAME = DATASET_INDEX_TABLE.file


@dataclass(frozen=True)
class FrameSet:
    """Frames held in memory at the training size.

    Attributes:
        images: ``(N, H, W, 3)`` uint8 BGR images (or ``(N, H, W, 1)`` grayscale).
        targets: ``(N, H, W)`` uint8: node codes (segmentation) or ``{0, 1}`` (corridor).
        names: Frame names (image file names), for reports.
    """

    images: NDArray[np.uint8]
    targets: NDArray[np.uint8]
    names: tuple[str, ...]


def read_index(data_dir: str | os.PathLike[str], column: str) -> tuple[Path, pd.DataFrame]:
    """Return the dataset folder and its index rows that have ``image`` and ``column``.

    Raises:
        TrainingError: If the index is missing, unreadable or lacks the columns.
    """
    root = Path(data_dir)
    index = root / INDEX_NAME
    if not index.is_file():
        raise TrainingError(
            f"{root} is not a dataset folder: no {INDEX_NAME} (run `slt simulate dataset`)"
        )
    try:
        table = pd.read_parquet(index)
    except (OSError, ValueError) as err:
        raise TrainingError(f"cannot read {index}: {err}") from err
    missing = [c for c in ("image", column) if c not in table.columns]
    if missing:
        raise TrainingError(f"{index} lacks column(s) {missing}; has {list(table.columns)}")
    rows = table[table[column].notna() & (table[column].astype(str) != "")]
    if rows.empty:
        raise TrainingError(f"{index}: no frame has a {column!r} image")
    return root, rows.reset_index(drop=True)


def _read(path: Path, flags: int) -> NDArray[np.uint8]:
    import cv2

    image = cv2.imread(str(path), flags)
    if image is None:
        raise TrainingError(f"cannot read image {path}")
    return np.asarray(image, dtype=np.uint8)


def _nearest(labels: NDArray[np.uint8], width: int, height: int) -> NDArray[np.uint8]:
    import cv2

    resized = cv2.resize(labels, (width, height), interpolation=cv2.INTER_NEAREST)
    return np.asarray(resized, dtype=np.uint8)


def load_frames(
    data_dir: str | os.PathLike[str],
    task: str,
    size: tuple[int, int],
    adapter: DatasetAdapter | None = None,
    max_frames: int | None = None,
    rows: slice | None = None,
) -> FrameSet:
    """Load a dataset's frames at ``size = (width, height)`` pixels.

    Args:
        data_dir: Dataset folder with ``index.parquet``.
        task: ``segmentation`` (targets are node codes via ``adapter``) or ``corridor``
            (grayscale images, binary corridor targets).
        size: Training ``(width, height)`` in pixels.
        adapter: Label adapter for segmentation (required for it).
        max_frames: Keep at most this many frames (the first ones, after ``rows``).
        rows: Slice of the index rows to use (e.g. a held-out tail).

    Raises:
        TrainingError: If the folder, index or an image cannot be read.
    """
    import cv2

    column = "labels" if task == "segmentation" else "corridor"
    root, table = read_index(data_dir, column)
    if rows is not None:
        table = table.iloc[rows]
    if max_frames is not None:
        table = table.iloc[: max(0, int(max_frames))]
    if table.empty:
        raise TrainingError(f"{root}: no frames selected")
    width, height = size
    images: list[NDArray[np.uint8]] = []
    targets: list[NDArray[np.uint8]] = []
    for image_rel, target_rel in zip(table["image"], table[column], strict=True):
        image = _read(root / str(image_rel), cv2.IMREAD_COLOR)
        image = np.asarray(
            cv2.resize(image, (width, height), interpolation=cv2.INTER_AREA), np.uint8
        )
        target = _read(root / str(target_rel), cv2.IMREAD_UNCHANGED)
        if target.ndim == 3:
            target = target[:, :, 0]
        if task == "segmentation":
            assert adapter is not None
            codes = adapter.to_codes(target)
            target = _nearest(codes, width, height)
            images.append(image)
        else:
            mask = (target > 0).astype(np.uint8)
            target = _nearest(mask, width, height)
            images.append(np.asarray(cv2.cvtColor(image, cv2.COLOR_BGR2GRAY), np.uint8)[:, :, None])
        targets.append(target)
    names = tuple(Path(str(p)).name for p in table["image"])
    return FrameSet(np.stack(images), np.stack(targets), names)


@dataclass(frozen=True)
class AugmentParams:
    """Torch-side photometric and geometric augmentation (domain randomisation on top of the sim).

    Attributes:
        brightness: Max relative brightness change (gain in ``1 +- brightness``).
        contrast: Max relative contrast change around the image mean.
        channel_gain: Max per-channel gain change (colour cast; ignored for grayscale).
        blur_prob: Probability of a Gaussian blur (sigma 0.5-1.5 px).
        noise_std: Max standard deviation of additive Gaussian noise (on the [0, 1] scale).
        flip_prob: Probability of a horizontal flip of image and target together.
    """

    brightness: float = 0.35
    contrast: float = 0.35
    channel_gain: float = 0.12
    blur_prob: float = 0.3
    noise_std: float = 0.04
    flip_prob: float = 0.5


def _blur(images: torch.Tensor, sigma: float) -> torch.Tensor:
    radius = max(1, round(2 * sigma))
    xs = torch.arange(-radius, radius + 1, dtype=images.dtype)
    kernel = torch.exp(-(xs**2) / (2 * sigma**2))
    kernel = kernel / kernel.sum()
    channels = images.shape[1]
    kx = kernel.view(1, 1, 1, -1).repeat(channels, 1, 1, 1)
    ky = kernel.view(1, 1, -1, 1).repeat(channels, 1, 1, 1)
    out = F.conv2d(F.pad(images, (radius, radius, 0, 0), mode="replicate"), kx, groups=channels)
    return F.conv2d(F.pad(out, (0, 0, radius, radius), mode="replicate"), ky, groups=channels)


def augment(
    images: torch.Tensor, targets: torch.Tensor, params: AugmentParams, gen: torch.Generator
) -> tuple[torch.Tensor, torch.Tensor]:
    """Augment a batch: ``images`` ``(N, C, H, W)`` in ``[0, 1]``, ``targets`` ``(N, H, W)``.

    Every random draw comes from ``gen``, so a seeded generator reproduces the batch exactly.
    """
    n, channels = images.shape[:2]

    def uniform(*shape: int, low: float, high: float) -> torch.Tensor:
        return low + (high - low) * torch.rand(*shape, generator=gen)

    gain = uniform(n, 1, 1, 1, low=1 - params.brightness, high=1 + params.brightness)
    if channels == 3:
        gain = gain * uniform(n, 3, 1, 1, low=1 - params.channel_gain, high=1 + params.channel_gain)
    out = images * gain
    mean = out.mean(dim=(1, 2, 3), keepdim=True)
    contrast = uniform(n, 1, 1, 1, low=1 - params.contrast, high=1 + params.contrast)
    out = (out - mean) * contrast + mean
    blur = torch.rand(n, generator=gen) < params.blur_prob
    sigmas = uniform(n, low=0.5, high=1.5)
    for i in torch.nonzero(blur).flatten().tolist():
        out[i : i + 1] = _blur(out[i : i + 1], float(sigmas[i]))
    noise = uniform(n, 1, 1, 1, low=0.0, high=params.noise_std)
    out = out + noise * torch.randn(out.shape, generator=gen)
    flip = torch.rand(n, generator=gen) < params.flip_prob
    if bool(flip.any()):
        out[flip] = out[flip].flip(-1)
        targets = targets.clone()
        targets[flip] = targets[flip].flip(-1)
    return out.clamp(0.0, 1.0), targets
