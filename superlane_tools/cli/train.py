"""`slt train`: train the segmentation or corridor network on real and simulated data."""

from __future__ import annotations

import inspect
from dataclasses import replace
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
from superlane_tools.errors import UsageError

TASKS = ("segmentation", "corridor")


def _size(text: str | None) -> tuple[int, int] | None:
    if text is None:
        return None
    try:
        width, height = (int(v) for v in text.lower().split("x"))
    except ValueError as err:
        raise UsageError(f"size must look like WIDTHxHEIGHT (e.g. 512x288), got {text!r}") from err
    return width, height


def train(
    task: Annotated[str, typer.Argument(metavar="TASK", help="segmentation or corridor.")],
    out: Annotated[Path, typer.Option("--out", help="Output MODEL.onnx (card written beside).")],
    data: Annotated[
        list[str] | None,
        typer.Option(
            "--data",
            metavar="[READER[:WEIGHT]=]DIR",
            help=(
                "Dataset: sim (a `slt simulate dataset` folder, the default), tusimple "
                "(labels.json), camvid, or an adapter name; WEIGHT = sampling weight. Repeat."
            ),
        ),
    ] = None,
    datasets: Annotated[
        Path | None,
        typer.Option("--datasets", help="YAML list of datasets (reader, folder, weight, ...)."),
    ] = None,
    epochs: Annotated[int, typer.Option("--epochs", min=1, help="Passes over the data.")] = 10,
    steps: Annotated[
        int | None, typer.Option("--steps", min=1, help="Optimiser steps (overrides --epochs).")
    ] = None,
    batch: Annotated[int, typer.Option("--batch", min=1, help="Frames per step.")] = 8,
    lr: Annotated[float, typer.Option("--lr", min=1e-7, help="Adam learning rate.")] = 2e-3,
    size: Annotated[
        str | None,
        typer.Option(
            "--size", help="Network input WxH (default 512x288 segmentation, 652x360 corridor)."
        ),
    ] = None,
    crop: Annotated[
        str | None, typer.Option("--crop", help="Train on random WxH crops (faster steps).")
    ] = None,
    seed: Annotated[int, typer.Option("--seed", help="Seed of init, shuffling, augmentation.")] = 0,
    max_frames: Annotated[
        int | None, typer.Option("--max-frames", min=1, help="Use at most N frames.")
    ] = None,
    adapter: Annotated[
        str,
        typer.Option("--adapter", help="Label adapter (superlane, cityscapes, ..., or a YAML)."),
    ] = "superlane",
    threads: Annotated[
        int | None,
        typer.Option("--threads", min=1, help="torch CPU threads (default: every core)."),
    ] = None,
    arch: Annotated[
        str,
        typer.Option(
            "--arch",
            help="Network: super, lite0, lite0-slim, lite0-s16 or lite0-s16-tiny "
            "(segmentation); fast or paper (corridor).",
        ),
    ] = "",
    augment: Annotated[
        str,
        typer.Option(
            "--augment",
            help="Augmentation: real (default), camera (wider camera geometry, night), "
            "canonical (camera's photometry, little geometry: for --canonical-camera), none.",
        ),
    ] = "real",
    budget_s: Annotated[
        float | None,
        typer.Option(
            "--budget-s", min=1, help="Wall-clock budget, s: the LR schedule follows it; stop then."
        ),
    ] = None,
    dice_bands: Annotated[
        int, typer.Option("--dice-bands", min=1, help="Row bands of the lane-marking Dice.")
    ] = 1,
    device: Annotated[str, typer.Option("--device", help="torch device: cpu or cuda.")] = "cpu",
    init: Annotated[
        Path | None, typer.Option("--init", help="Start from a checkpoint's weights (fine-tune).")
    ] = None,
    resume: Annotated[
        bool,
        typer.Option("--resume", help="Continue from the checkpoint if it exists (more steps OK)."),
    ] = False,
    checkpoint: Annotated[
        Path | None,
        typer.Option("--checkpoint", help="Resumable checkpoint (default MODEL.ckpt.pt)."),
    ] = None,
    checkpoint_s: Annotated[
        float, typer.Option("--checkpoint-every-s", min=0, help="Save it every S seconds.")
    ] = 300.0,
    validate_every: Annotated[
        int, typer.Option("--validate-every", min=0, help="Validate every N steps (0: off).")
    ] = 300,
    val_data: Annotated[
        Path | None,
        typer.Option("--val-data", help="Real-data folder of the dev sets (validation)."),
    ] = None,
    canonical_camera: Annotated[
        bool,
        typer.Option(
            "--canonical-camera",
            help="Resample frames with a known or estimated camera into the canonical camera.",
        ),
    ] = False,
    overwrite: Annotated[bool, overwrite_option()] = False,
) -> None:
    """Train a network on CPU, export it to ONNX (opset 17) and write MODEL.card.yaml."""
    with cli_errors():
        check_new_output(out, overwrite or resume)
        if task not in TASKS:
            raise UsageError(f"TASK must be one of {', '.join(TASKS)}, got {task!r}")
        if augment not in ("real", "camera", "canonical", "none"):
            raise UsageError(f"--augment must be real, camera, canonical or none, got {augment!r}")
        from superlane_tools.training import require_torch

        require_torch()
        from superlane_tools.training.augment import (
            CAMERA_AUGMENT,
            CANONICAL_AUGMENT,
            RealAugment,
        )
        from superlane_tools.training.datasets import load_dataset_list, parse_data_arg
        from superlane_tools.training.train import TrainParams
        from superlane_tools.training.train import train as run_training

        specs = [parse_data_arg(text) for text in data or []]
        if adapter != "superlane":
            specs = [replace(s, reader=adapter) if s.reader == "sim" else s for s in specs]
        if datasets is not None:
            specs += load_dataset_list(datasets)
        if not specs:
            raise UsageError("give training data with --data or --datasets")
        params = TrainParams(
            task=task,
            data_dir=None,
            datasets=tuple(specs),
            out=out,
            epochs=epochs,
            steps=steps,
            arch=arch,
            dice_bands=dice_bands,
            device=device,
            resume=resume,
            init=init,
            budget_s=budget_s,
            augment={
                "real": RealAugment(),
                "camera": CAMERA_AUGMENT,
                "canonical": CANONICAL_AUGMENT,
                "none": None,
            }[augment],
            canonical_camera=canonical_camera,
            batch=batch,
            lr=lr,
            size=_size(size),
            crop=_size(crop),
            seed=seed,
            max_frames=max_frames,
            adapter=adapter,
            command=command_line(),
            checkpoint=checkpoint,
            checkpoint_s=checkpoint_s,
            validate_every=validate_every,
            val_data=val_data,
        )
        if threads is not None:
            params = replace(params, threads=threads)
        with (  # --resume continues into the same MODEL.onnx
            new_output(out, overwrite or resume, replaces=True),
            progress(f"train {task}", unit="steps") as bar,
        ):

            def update(step: int, total: int, loss: float) -> None:
                bar.update(step, total, note=f"loss {loss:.4f}")

            result = run_training(params, update, note)
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
