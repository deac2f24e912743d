"""`slt train`: train the segmentation or corridor network, export it to ONNX with its card."""

from __future__ import annotations

from collections.abc import Callable
from contextlib import nullcontext
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING

from superlane_tools.commands.options import OutputGuard, ProgressOpener
from superlane_tools.errors import UsageError

if TYPE_CHECKING:
    from superlane_tools.training.train import TrainResult

TASKS = ("segmentation", "corridor")
AUGMENTS = ("real", "camera", "canonical", "none")


@dataclass(frozen=True)
class TrainOptions:
    """What ``slt train`` was asked, as typed (see its options); checked by :func:`run`."""

    task: str
    out: Path
    data: list[str] = field(default_factory=list)
    datasets: Path | None = None
    epochs: int = 10
    steps: int | None = None
    batch: int = 8
    lr: float = 2e-3
    size: str | None = None
    crop: str | None = None
    seed: int = 0
    max_frames: int | None = None
    adapter: str = "superlane"
    threads: int | None = None
    arch: str = ""
    augment: str = "real"
    budget_s: float | None = None
    dice_bands: int = 1
    device: str = "cpu"
    init: Path | None = None
    resume: bool = False
    checkpoint: Path | None = None
    checkpoint_s: float = 300.0
    validate_every: int = 300
    val_data: Path | None = None
    validate_against: str | None = None
    canonical_camera: bool = False
    canonical_near_m: float | None = None
    command: str = ""
    output_guard: OutputGuard = field(default_factory=nullcontext)


def _size(text: str | None) -> tuple[int, int] | None:
    if text is None:
        return None
    try:
        width, height = (int(v) for v in text.lower().split("x"))
    except ValueError as err:
        raise UsageError(f"size must look like WIDTHxHEIGHT (e.g. 512x288), got {text!r}") from err
    return width, height


def run(
    options: TrainOptions, progress: ProgressOpener, note: Callable[[str], None]
) -> TrainResult:
    """Check the options, train, export the model and write its card.

    Args:
        options: What to train and how.
        progress: Opens the progress display of the training steps.
        note: Prints one line (seconds per step, validation results).

    Raises:
        UsageError: A bad task, augmentation, size or no training data.
    """
    o = options
    if o.task not in TASKS:
        raise UsageError(f"TASK must be one of {', '.join(TASKS)}, got {o.task!r}")
    if o.augment not in AUGMENTS:
        raise UsageError(f"--augment must be real, camera, canonical or none, got {o.augment!r}")
    from superlane_tools.training import require_torch

    require_torch()
    from superlane_tools.training.augment import CAMERA_AUGMENT, CANONICAL_AUGMENT, RealAugment
    from superlane_tools.training.datasets import load_dataset_list, parse_data_arg
    from superlane_tools.training.train import TrainParams, train

    specs = [parse_data_arg(text) for text in o.data]
    if o.adapter != "superlane":
        specs = [replace(s, reader=o.adapter) if s.reader == "sim" else s for s in specs]
    if o.datasets is not None:
        specs += load_dataset_list(o.datasets)
    if not specs:
        raise UsageError("give training data with --data or --datasets")
    augment = {
        "real": RealAugment(),
        "camera": CAMERA_AUGMENT,
        "canonical": CANONICAL_AUGMENT,
        "none": None,
    }[o.augment]
    params = TrainParams(
        task=o.task,
        data_dir=None,
        datasets=tuple(specs),
        out=o.out,
        epochs=o.epochs,
        steps=o.steps,
        arch=o.arch,
        dice_bands=o.dice_bands,
        device=o.device,
        resume=o.resume,
        init=o.init,
        budget_s=o.budget_s,
        augment=augment,
        canonical_camera=o.canonical_camera,
        canonical_near_m=o.canonical_near_m,
        batch=o.batch,
        lr=o.lr,
        size=_size(o.size),
        crop=_size(o.crop),
        seed=o.seed,
        max_frames=o.max_frames,
        adapter=o.adapter,
        command=o.command,
        checkpoint=o.checkpoint,
        checkpoint_s=o.checkpoint_s,
        validate_every=o.validate_every,
        val_data=o.val_data,
        validate_against=o.validate_against,
    )
    if o.threads is not None:
        params = replace(params, threads=o.threads)
    with o.output_guard, progress() as bar:

        def update(step: int, total: int, loss: float) -> None:
            bar.update(step, total, note=f"loss {loss:.4f}")

        return train(params, update, note)
