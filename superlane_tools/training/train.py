"""Train the segmentation and corridor networks on CPU, export to ONNX, write the model card.

Reproducible: one seed drives weight initialisation, shuffling and augmentation; torch runs on
``threads`` CPU threads. Import this module only after :func:`require_torch` succeeded (the
``train`` extra); the CLI does so.
"""

from __future__ import annotations

import contextlib
import os
import platform
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import torch
from torch import nn

from superlane_tools.reporting.provenance import file_sha256
from superlane_tools.scene.adapters.heads import HEADS, IGNORE, head_target_lut
from superlane_tools.scene.adapters.loader import load_adapter
from superlane_tools.scene.model_card import (
    InputSpec,
    ModelCard,
    OutputSpec,
    card_path_for,
    write_card,
)
from superlane_tools.training._blocks import count_parameters
from superlane_tools.training.corridor_net import EgoCorridorNet
from superlane_tools.training.data import INDEX_NAME, AugmentParams, FrameSet, augment, load_frames
from superlane_tools.training.errors import TrainingError
from superlane_tools.training.export import OPSET, export_onnx
from superlane_tools.training.losses import corridor_loss, segmentation_loss
from superlane_tools.training.seg_net import HierarchicalSegNet

TASKS = ("segmentation", "corridor")
DEFAULT_SIZE: dict[str, tuple[int, int]] = {"segmentation": (512, 288), "corridor": (652, 360)}
MEAN, STD = 0.45, 0.25
HEAD_WEIGHTS = (1.0, 0.5, 1.0, 1.5, 1.0)
"""Loss weight per head (root, vertical, support, drivable, lane_marking)."""

Progress = Callable[[int, int, float], None]
"""Called after every step with ``(step, total_steps, loss)``."""


@dataclass(frozen=True)
class TrainParams:
    """What to train and how.

    Attributes:
        task: ``segmentation`` or ``corridor``.
        data_dir: Dataset folder (``index.parquet`` + images).
        extra_data: More dataset folders, concatenated after ``data_dir`` (e.g. several
            ``slt simulate dataset`` runs with different seeds).
        out: Target ``.onnx`` path; the card is written beside it.
        epochs: Passes over the data.
        batch: Frames per step.
        lr: Adam learning rate.
        size: Network input ``(width, height)`` in pixels; None for the task default
            (segmentation 512x288, corridor 652x360).
        seed: Seed of initialisation, shuffling and augmentation.
        max_frames: Use at most this many frames (the first ones).
        adapter: Dataset adapter of the label images (segmentation only).
        threads: torch CPU threads.
        augment: Augmentation parameters, or None to train on the frames as they are.
        crop: Train on random ``(width, height)`` crops of the frames (same scale, fewer
            pixels per step; the network is fully convolutional and is exported at ``size``).
        marking_dice: Weight of the lane-marking Dice loss (segmentation; 0 = cross-entropy only).
        corridor_dice: Weight of the Dice loss added to the corridor BCE (0 = BCE only).
        name: Model name for the card (default: the output file stem).
        command: The command line that started training, recorded in the card.
    """

    task: str
    data_dir: Path
    out: Path
    extra_data: tuple[Path, ...] = ()
    epochs: int = 10
    batch: int = 8
    lr: float = 2e-3
    size: tuple[int, int] | None = None
    seed: int = 0
    max_frames: int | None = None
    adapter: str = "superlane"
    threads: int = 2
    augment: AugmentParams | None = field(default_factory=AugmentParams)
    crop: tuple[int, int] | None = None
    marking_dice: float = 1.0
    corridor_dice: float = 1.0
    name: str = ""
    command: str = ""

    @property
    def input_size(self) -> tuple[int, int]:
        """The network input ``(width, height)`` in pixels."""
        return self.size or DEFAULT_SIZE[self.task]


@dataclass(frozen=True)
class TrainResult:
    """Outcome of one training run.

    Attributes:
        model_path: The exported ONNX file.
        card_path: Its model card.
        card: The card written.
        step_losses: Training loss of every step, in order.
        epoch_losses: Mean training loss per epoch.
        seconds: Wall time of the training loop, seconds.
    """

    model_path: Path
    card_path: Path
    card: ModelCard
    step_losses: tuple[float, ...]
    epoch_losses: tuple[float, ...]
    seconds: float


@contextlib.contextmanager
def _torch_threads(threads: int) -> Iterator[None]:
    before = torch.get_num_threads()
    torch.set_num_threads(max(1, threads))
    try:
        yield
    finally:
        torch.set_num_threads(before)


def _class_weights(codes: np.ndarray[Any, Any]) -> list[torch.Tensor | None]:
    """Return per-head class weights ``(median freq / freq) ** 0.5``, clipped to [0.2, 10]."""
    weights: list[torch.Tensor | None] = []
    for head in HEADS:
        target = head_target_lut(head)[codes]
        counts = np.bincount(target[target != IGNORE], minlength=len(head.classes)).astype(float)
        seen = counts > 0
        if not seen.any():
            weights.append(None)
            continue
        freq = np.where(seen, counts, np.nan) / counts.sum()
        w = np.sqrt(np.nanmedian(freq) / freq)
        w = np.clip(np.nan_to_num(w, nan=1.0), 0.2, 10.0)
        weights.append(torch.tensor(w, dtype=torch.float32))
    return weights


def _load_all(params: TrainParams, size: tuple[int, int], adapter: Any) -> FrameSet:
    """Load ``data_dir`` and every ``extra_data`` folder; ``max_frames`` caps the total."""
    sets: list[FrameSet] = []
    left = params.max_frames
    for folder in (params.data_dir, *params.extra_data):
        if left is not None and left <= 0:
            break
        sets.append(load_frames(folder, params.task, size, adapter, left))
        left = None if left is None else left - len(sets[-1].names)
    if len(sets) == 1:
        return sets[0]
    return FrameSet(
        np.concatenate([s.images for s in sets]),
        np.concatenate([s.targets for s in sets]),
        tuple(n for s in sets for n in s.names),
    )


def _dataset_command(data_dir: Path) -> str:
    try:
        from superlane_tools.reporting.parquet import read_provenance

        return str(read_provenance(data_dir / INDEX_NAME).get("command", ""))
    except Exception:  # a dataset without provenance is fine; the card then says so
        return ""


def _input_spec(task: str, size: tuple[int, int]) -> InputSpec:
    if task == "segmentation":
        return InputSpec("image", size[0], size[1], "RGB", (MEAN,) * 3, (STD,) * 3)
    return InputSpec("image", size[0], size[1], "GRAY", (MEAN,), (STD,))


def _outputs(task: str) -> tuple[OutputSpec, ...]:
    if task == "segmentation":
        return tuple(OutputSpec(h.name, "logits", h.parent, h.classes) for h in HEADS)
    return (OutputSpec("corridor", "probability"),)


def train(params: TrainParams, progress: Progress | None = None) -> TrainResult:
    """Train one network, export it to ONNX and write its model card.

    Args:
        params: What to train and how.
        progress: Optional callback after every step.

    Raises:
        TrainingError: If the parameters or the dataset are invalid, or export fails.
    """
    if params.task not in TASKS:
        raise TrainingError(f"unknown task {params.task!r} (known: {', '.join(TASKS)})")
    if params.epochs < 1 or params.batch < 1 or params.lr <= 0:
        raise TrainingError("epochs and batch must be >= 1 and lr > 0")
    width, height = params.input_size
    if width < 16 or height < 16:
        raise TrainingError(f"input size {width}x{height} is too small (min 16x16)")
    adapter = load_adapter(params.adapter) if params.task == "segmentation" else None
    frames = _load_all(params, (width, height), adapter)
    torch.manual_seed(params.seed)
    gen = torch.Generator().manual_seed(params.seed)
    with _torch_threads(params.threads):
        model: nn.Module = (
            HierarchicalSegNet() if params.task == "segmentation" else EgoCorridorNet()
        )
        start = time.perf_counter()
        step_losses, epoch_losses = _fit(model, frames, params, gen, progress)
        seconds = time.perf_counter() - start
        spec = _input_spec(params.task, (width, height))
        outputs = _outputs(params.task)
        max_diff = export_onnx(
            model, spec.shape, params.out, spec.name, [o.name for o in outputs], params.seed
        )
    card = ModelCard(
        name=params.name or params.out.name.removesuffix(".onnx"),
        task=params.task,
        input=spec,
        outputs=outputs,
        sha256=file_sha256(params.out),
        parameters=count_parameters(model),
        description=_DESCRIPTIONS[params.task],
        training={
            "data": [str(d) for d in (params.data_dir, *params.extra_data)],
            "frames": len(frames.names),
            "dataset_command": " ; ".join(
                _dataset_command(d) or f"unknown for {d} (no provenance)"
                for d in (params.data_dir, *params.extra_data)
            ),
            "training_command": params.command or "library call",
            "adapter": params.adapter if params.task == "segmentation" else "n/a",
            "seed": params.seed,
            "epochs": params.epochs,
            "batch": params.batch,
            "lr": params.lr,
            "augmentation": "none" if params.augment is None else str(params.augment),
            "crop": "full frames" if params.crop is None else list(params.crop),
            "loss": _loss_text(params),
            "final_epoch_loss": round(epoch_losses[-1], 5),
            "train_seconds": round(seconds, 1),
            "torch_version": str(torch.__version__),
            "opset": OPSET,
            "onnx_vs_torch_max_abs_diff": float(f"{max_diff:.3g}"),
            "machine": f"{platform.machine()} {params.threads} threads",
        },
    )
    card_path = write_card(card, card_path_for(params.out))
    return TrainResult(params.out, card_path, card, step_losses, epoch_losses, seconds)


def _loss_text(params: TrainParams) -> str:
    if params.task == "segmentation":
        text = "per-head cross-entropy, class weights (median freq / freq) ** 0.5"
        dice = params.marking_dice
        return text + (f" + {dice} x soft Dice on P(lane_marking)" if dice > 0 else "")
    dice = params.corridor_dice
    return "BCE on logits" + (f" + {dice} x soft Dice" if dice > 0 else "")


_DESCRIPTIONS = {
    "segmentation": (
        "Hierarchical scene segmentation (SUPER Fig. 3): depthwise-separable encoder-decoder "
        "with one softmax head per parent node; decode by argmax down the tree."
    ),
    "corridor": (
        "Ego-corridor network (corridor paper III): grayscale in, per-pixel probability that "
        "the pixel is in the ego lane up to the preceding vehicle."
    ),
}


def _batch_tensors(
    frames: FrameSet, idx: np.ndarray[Any, Any], task: str
) -> tuple[torch.Tensor, torch.Tensor]:
    images = frames.images[idx]
    if task == "segmentation":
        images = images[..., ::-1]  # BGR -> RGB, the card's colour order
    x = torch.from_numpy(np.ascontiguousarray(images)).permute(0, 3, 1, 2).float() / 255.0
    y = torch.from_numpy(frames.targets[idx].astype(np.int64))
    return x, y


def _random_crop(
    x: torch.Tensor, y: torch.Tensor, crop: tuple[int, int], gen: torch.Generator
) -> tuple[torch.Tensor, torch.Tensor]:
    width, height = min(crop[0], x.shape[-1]), min(crop[1], x.shape[-2])
    u0 = int(torch.randint(0, x.shape[-1] - width + 1, (1,), generator=gen))
    v0 = int(torch.randint(0, x.shape[-2] - height + 1, (1,), generator=gen))
    return x[..., v0 : v0 + height, u0 : u0 + width], y[..., v0 : v0 + height, u0 : u0 + width]


def _fit(
    model: nn.Module,
    frames: FrameSet,
    params: TrainParams,
    gen: torch.Generator,
    progress: Progress | None,
) -> tuple[tuple[float, ...], tuple[float, ...]]:
    optimizer = torch.optim.Adam(model.parameters(), lr=params.lr)
    n = len(frames.names)
    steps_per_epoch = max(1, -(-n // params.batch))
    total = steps_per_epoch * params.epochs
    scheduler = torch.optim.lr_scheduler.OneCycleLR(
        optimizer, max_lr=params.lr, total_steps=total, pct_start=0.15
    )
    luts = [torch.from_numpy(head_target_lut(h)) for h in HEADS]
    class_weights = _class_weights(frames.targets) if params.task == "segmentation" else []
    step_losses: list[float] = []
    epoch_losses: list[float] = []
    model.train()
    step = 0
    for _ in range(params.epochs):
        order = torch.randperm(n, generator=gen).numpy()
        losses: list[float] = []
        for first in range(0, n, params.batch):
            x, y = _batch_tensors(frames, order[first : first + params.batch], params.task)
            if params.crop is not None:
                x, y = _random_crop(x, y, params.crop, gen)
            if params.augment is not None:
                x, y = augment(x, y, params.augment, gen)
            x = (x - MEAN) / STD
            if params.task == "segmentation":
                targets = [lut[y] for lut in luts]
                logits = model(x)
                loss = segmentation_loss(
                    logits, targets, HEAD_WEIGHTS, class_weights, params.marking_dice
                )
            else:
                assert isinstance(model, EgoCorridorNet)
                loss = corridor_loss(model.logits(x), y.unsqueeze(1).float(), params.corridor_dice)
            optimizer.zero_grad(set_to_none=True)
            loss.backward()  # type: ignore[no-untyped-call]
            optimizer.step()
            scheduler.step()
            value = float(loss.detach())
            if not np.isfinite(value):
                raise TrainingError(f"training diverged at step {step} (loss {value}); lower --lr")
            losses.append(value)
            step_losses.append(value)
            step += 1
            if progress is not None:
                progress(step, total, value)
        epoch_losses.append(float(np.mean(losses)))
    model.eval()
    return tuple(step_losses), tuple(epoch_losses)


def default_out(task: str, folder: str | os.PathLike[str]) -> Path:
    """Return the default model path of ``task`` in ``folder``."""
    return Path(folder) / ("super_seg.onnx" if task == "segmentation" else "ego_corridor.onnx")
