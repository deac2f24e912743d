"""`slt train`: train the segmentation or corridor network on real and simulated data."""

from __future__ import annotations

import inspect
from pathlib import Path
from typing import Annotated

import typer

from superlane_tools.cli._common import (
    EXIT_CODES_HELP,
    cli_errors,
    command_line,
    note,
    progress,
)
from superlane_tools.cli._outputs import check_new_output, new_output, overwrite_option

# The options of `train`, as Typer reads them from the annotations.
_Task = Annotated[str, typer.Argument(metavar="TASK", help="segmentation or corridor.")]
_Out = Annotated[Path, typer.Option("--out", help="Output MODEL.onnx (card written beside).")]
_Data = Annotated[
    list[str] | None,
    typer.Option(
        "--data",
        metavar="[READER[:WEIGHT]=]DIR",
        help=(
            "Dataset: sim (a `slt simulate dataset` folder, the default), tusimple "
            "(labels.json), camvid, or an adapter name; WEIGHT = sampling weight. Repeat."
        ),
    ),
]
_Datasets = Annotated[
    Path | None,
    typer.Option("--datasets", help="YAML list of datasets (reader, folder, weight, ...)."),
]
_Epochs = Annotated[int, typer.Option("--epochs", min=1, help="Passes over the data.")]
_Steps = Annotated[
    int | None, typer.Option("--steps", min=1, help="Optimiser steps (overrides --epochs).")
]
_Batch = Annotated[int, typer.Option("--batch", min=1, help="Frames per step.")]
_Lr = Annotated[float, typer.Option("--lr", min=1e-7, help="Adam learning rate.")]
_Size = Annotated[
    str | None,
    typer.Option(
        "--size", help="Network input WxH (default 512x288 segmentation, 652x360 corridor)."
    ),
]
_Crop = Annotated[
    str | None, typer.Option("--crop", help="Train on random WxH crops (faster steps).")
]
_Seed = Annotated[int, typer.Option("--seed", help="Seed of init, shuffling, augmentation.")]
_MaxFrames = Annotated[
    int | None, typer.Option("--max-frames", min=1, help="Use at most N frames.")
]
_Adapter = Annotated[
    str,
    typer.Option("--adapter", help="Label adapter (superlane, cityscapes, ..., or a YAML)."),
]
_Threads = Annotated[
    int | None,
    typer.Option("--threads", min=1, help="torch CPU threads (default: every core)."),
]
_Arch = Annotated[
    str,
    typer.Option(
        "--arch",
        help="Network: super, lite0, lite0-slim, lite0-s16, lite0-s16-half or lite0-s16-tiny "
        "(segmentation); fast or paper (corridor).",
    ),
]
_Augment = Annotated[
    str,
    typer.Option(
        "--augment",
        help="Augmentation: real (default), camera (wider camera geometry, night), "
        "canonical (camera's photometry, little geometry: for --canonical-camera), none.",
    ),
]
_BudgetS = Annotated[
    float | None,
    typer.Option(
        "--budget-s", min=1, help="Wall-clock budget, s: the LR schedule follows it; stop then."
    ),
]
_DiceBands = Annotated[
    int, typer.Option("--dice-bands", min=1, help="Row bands of the lane-marking Dice.")
]
_Device = Annotated[str, typer.Option("--device", help="torch device: cpu or cuda.")]
_Init = Annotated[
    Path | None, typer.Option("--init", help="Start from a checkpoint's weights (fine-tune).")
]
_Resume = Annotated[
    bool,
    typer.Option("--resume", help="Continue from the checkpoint if it exists (more steps OK)."),
]
_Checkpoint = Annotated[
    Path | None,
    typer.Option("--checkpoint", help="Resumable checkpoint (default MODEL.ckpt.pt)."),
]
_CheckpointS = Annotated[
    float, typer.Option("--checkpoint-every-s", min=0, help="Save it every S seconds.")
]
_ValidateEvery = Annotated[
    int, typer.Option("--validate-every", min=0, help="Validate every N steps (0: off).")
]
_ValData = Annotated[
    Path | None,
    typer.Option("--val-data", help="Real-data folder of the dev sets (validation)."),
]
_ValidateAgainst = Annotated[
    str | None,
    typer.Option(
        "--validate-against",
        metavar="MODEL",
        help="Keep the weights with the best worst margin over this model's dev-set scores.",
    ),
]
_CanonicalCamera = Annotated[
    bool,
    typer.Option(
        "--canonical-camera",
        help="Resample frames with a known or estimated camera into the canonical camera.",
    ),
]
_CanonicalNearM = Annotated[
    float | None,
    typer.Option(
        "--canonical-near-m",
        min=0.5,
        help="The canonical camera's bottom row sees the road this far ahead, m (default 5).",
    ),
]
_Overwrite = Annotated[bool, overwrite_option()]


def train(
    task: _Task,
    out: _Out,
    data: _Data = None,
    datasets: _Datasets = None,
    epochs: _Epochs = 10,
    steps: _Steps = None,
    batch: _Batch = 8,
    lr: _Lr = 2e-3,
    size: _Size = None,
    crop: _Crop = None,
    seed: _Seed = 0,
    max_frames: _MaxFrames = None,
    adapter: _Adapter = "superlane",
    threads: _Threads = None,
    arch: _Arch = "",
    augment: _Augment = "real",
    budget_s: _BudgetS = None,
    dice_bands: _DiceBands = 1,
    device: _Device = "cpu",
    init: _Init = None,
    resume: _Resume = False,
    checkpoint: _Checkpoint = None,
    checkpoint_s: _CheckpointS = 300.0,
    validate_every: _ValidateEvery = 300,
    val_data: _ValData = None,
    validate_against: _ValidateAgainst = None,
    canonical_camera: _CanonicalCamera = False,
    canonical_near_m: _CanonicalNearM = None,
    overwrite: _Overwrite = False,
) -> None:
    """Train a network on CPU, export it to ONNX (opset 17) and write MODEL.card.yaml."""
    from superlane_tools.commands.train import TrainOptions, run

    with cli_errors():
        check_new_output(out, overwrite or resume)
        options = TrainOptions(
            task,
            out,
            data or [],
            datasets,
            epochs,
            steps,
            batch,
            lr,
            size,
            crop,
            seed,
            max_frames,
            adapter,
            threads,
            arch,
            augment,
            budget_s,
            dice_bands,
            device,
            init,
            resume,
            checkpoint,
            checkpoint_s,
            validate_every,
            val_data,
            validate_against,
            canonical_camera,
            canonical_near_m,
            command_line(),
            # --resume continues into the same MODEL.onnx
            new_output(out, overwrite or resume, replaces=True),
        )
        result = run(options, lambda: progress(f"train {task}", unit="steps"), note)
        note(
            f"trained {task} model ({result.card.parameters} parameters, "
            f"{result.seconds:.0f} s, {result.seconds_per_step:.2f} s per step, "
            f"final loss {result.epoch_losses[-1]:.4f}) -> "
            f"{result.model_path} + {result.card_path.name}"
        )


def register(app: typer.Typer) -> None:
    """Add ``slt train`` to the root app."""
    doc = inspect.cleandoc(train.__doc__ or "")
    app.command("train", help=f"{doc}\n\n{EXIT_CODES_HELP}")(train)
