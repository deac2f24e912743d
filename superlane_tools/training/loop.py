"""The training loop: batches, loss, schedule, checkpoints, resume and validation.

Resumable across runs and machines: the checkpoint (written atomically every ``checkpoint_every``
steps, every ``checkpoint_s`` seconds and at the end) holds the weights, the optimizer, the
sampling generator, the losses, the step and the training seconds so far; the learning-rate
schedule is a function of progress (:mod:`superlane_tools.training.schedule`), rebuilt from the
resumed run's own total, so a run may resume with more steps or a longer budget than the first.
Import only after :func:`~superlane_tools.training._torch.require_torch` succeeded.
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import torch
from torch import nn

from superlane_tools.scene.adapters.heads import HEADS, IGNORE, head_target_lut
from superlane_tools.scene.model_card import InputSpec
from superlane_tools.training.augment import MIRROR_SWAP, affine_theta, jpeg, photometric, warp
from superlane_tools.training.checkpoint import load_checkpoint, save_checkpoint
from superlane_tools.training.corridor_net import EgoCorridorNet, PaperCorridorNet
from superlane_tools.training.datasets import LoadedSet
from superlane_tools.training.errors import TrainingError
from superlane_tools.training.lite_seg_net import LiteHalfResolutionHeads, LiteHierarchicalSegNet
from superlane_tools.training.losses import corridor_loss, segmentation_loss
from superlane_tools.training.schedule import Schedule
from superlane_tools.training.seg_net import HalfResolutionHeads, HierarchicalSegNet
from superlane_tools.training.tusimple_targets import CORRIDOR_IGNORE

HEAD_WEIGHTS = (1.0, 0.5, 1.0, 1.5, 1.0)
"""Loss weight per head (root, vertical, support, drivable, lane_marking)."""
Progress = Callable[[int, int, float], None]
"""Called after every step with ``(step, total_steps, loss)``."""
Note = Callable[[str], None]
"""Called with one-line messages (seconds per step, checkpoints, validation)."""
TIMING_STEPS = 10
"""Seconds per step are reported after this many steps of a run (start-up excluded)."""


def _class_weights(sets: Sequence[LoadedSet]) -> list[torch.Tensor | None]:
    """Return per-head class weights ``(median freq / freq) ** 0.5``, clipped to [0.2, 10].

    Pixel counts come from every dataset that trains the head.
    """
    weights: list[torch.Tensor | None] = []
    for k, head in enumerate(HEADS):
        lut = head_target_lut(head)
        counts = np.zeros(len(head.classes), float)
        for loaded in sets:
            if loaded.codes is None or not loaded.heads[k]:
                continue
            code_counts = np.bincount(loaded.codes.ravel(), minlength=256)
            for code in np.nonzero(code_counts)[0]:
                if lut[code] != IGNORE:
                    counts[lut[code]] += code_counts[code]
        seen = counts > 0
        if not seen.any():
            weights.append(None)
            continue
        freq = np.where(seen, counts, np.nan) / counts.sum()
        w = np.sqrt(np.nanmedian(freq) / freq)
        w = np.clip(np.nan_to_num(w, nan=1.0), 0.2, 10.0)
        weights.append(torch.tensor(w, dtype=torch.float32))
    return weights


def exported_module(model: nn.Module) -> nn.Module:
    """Return the module to export: segmentation heads stop at half resolution."""
    if isinstance(model, HierarchicalSegNet):
        return HalfResolutionHeads(model)
    if isinstance(model, LiteHierarchicalSegNet):
        return LiteHalfResolutionHeads(model)
    return model


def _sample(
    loaded: LoadedSet,
    index: int,
    params: Any,
    gen: torch.Generator,
    out_size: tuple[int, int],
) -> tuple[torch.Tensor, torch.Tensor]:
    """Return one augmented ``(C, H, W)`` image in ``[0, 1]`` and its ``(H, W)`` target."""
    import cv2

    image = loaded.images[index]
    aug = params.augment
    if aug is not None and float(torch.rand((), generator=gen)) < aug.jpeg_prob:
        image = jpeg(image, int(torch.randint(25, 91, (), generator=gen)))
    if params.task == "segmentation":
        assert loaded.codes is not None
        pixels = np.ascontiguousarray(image[..., ::-1])  # BGR -> RGB, the card's colour order
        target, outside = loaded.codes[index], 0
    else:
        assert loaded.corridor is not None
        pixels = np.asarray(cv2.cvtColor(image, cv2.COLOR_BGR2GRAY), np.uint8)[..., None]
        target, outside = loaded.corridor[index], CORRIDOR_IGNORE
    x = torch.from_numpy(pixels).permute(2, 0, 1).float() / 255.0
    y = torch.from_numpy(np.ascontiguousarray(target))
    in_size = (x.shape[-1], x.shape[-2])
    random_crop = params.task == "segmentation"
    theta = affine_theta(in_size, out_size, aug, gen, random_crop)
    return warp(x, y, theta, out_size, outside, MIRROR_SWAP if random_crop else None)


def _batch(
    sets: Sequence[LoadedSet],
    probs: torch.Tensor,
    params: Any,
    gen: torch.Generator,
    out_size: tuple[int, int],
) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """Draw a batch: dataset by weight, frame uniformly; return images, targets, head masks."""
    xs, ys, heads = [], [], []
    for d in torch.multinomial(probs, params.batch, replacement=True, generator=gen).tolist():
        loaded = sets[d]
        index = int(torch.randint(len(loaded.names), (), generator=gen))
        x, y = _sample(loaded, index, params, gen, out_size)
        xs.append(x)
        ys.append(y)
        heads.append(loaded.heads)
    x = torch.stack(xs)
    if params.augment is not None:
        x = photometric(x, params.augment, gen)
    return x, torch.stack(ys), torch.tensor(heads, dtype=torch.bool)


def head_targets_masked(
    codes: torch.Tensor, heads: torch.Tensor, luts: Sequence[torch.Tensor]
) -> list[torch.Tensor]:
    """Return per-head targets of a code batch, ``IGNORE`` where a frame's dataset skips a head.

    Args:
        codes: ``(N, H, W)`` int64 node codes.
        heads: ``(N, n_heads)`` bool: does frame ``i``'s dataset train head ``k``.
        luts: Per-head code -> class tables.
    """
    targets = []
    for k, lut in enumerate(luts):
        target = lut[codes]
        target[~heads[:, k]] = IGNORE
        targets.append(target)
    return targets


@dataclass
class _Run:
    """What the loop carries between steps (restored on resume)."""

    losses: list[float]
    first: int
    elapsed_s: float
    step_s: list[float] = field(default_factory=list)
    validator: Any = None


@dataclass(frozen=True)
class Fitted:
    """What :func:`fit` returns."""

    step_losses: tuple[float, ...]
    epoch_losses: tuple[float, ...]
    seconds_per_step: float
    validation: dict[str, Any] | None


def _restore(
    model: nn.Module, optimizer: Any, gen: torch.Generator, params: Any, device: Any
) -> _Run:
    """Load the checkpoint on ``--resume`` or the ``--init`` weights; return where to start."""
    ckpt = params.checkpoint_path
    if params.resume and ckpt.is_file():
        state = load_checkpoint(ckpt, f"--resume {ckpt}", device)
        try:
            model.load_state_dict(state["model"])
            optimizer.load_state_dict(state["optimizer"])
            gen.set_state(state["generator"])
            run = _Run(list(state["losses"]), int(state["step"]), float(state.get("elapsed_s", 0)))
            history = json.loads(str(state.get("validation", "[]")))
        except (KeyError, RuntimeError, TypeError, ValueError) as err:
            raise TrainingError(f"--resume {ckpt}: not a checkpoint of this run: {err}") from err
        run.validator = history  # the validator is built later, with this history
        return run
    if params.init is not None:
        state = load_checkpoint(params.init, f"--init {params.init}", device)
        error = f"--init {params.init}: weights do not fit this {params.task} model"
        _load_init(model, state, error)
    return _Run([], 0, 0.0)


def _load_init(model: nn.Module, state: dict[str, Any], error: str) -> None:
    """Load ``--init`` weights: every tensor, except the modules a refining variant adds.

    A variant that refines another (``lite_seg_net.LiteVariant.refine_half``) keeps its new modules
    (:meth:`~superlane_tools.training.lite_seg_net.LiteHierarchicalSegNet.new_on_init`) as built
    when the checkpoint is the other variant's; anything else missing or left over is an error.
    """
    new = model.new_on_init() if isinstance(model, LiteHierarchicalSegNet) else ()
    try:
        result = model.load_state_dict(state["model"], strict=False)
    except (KeyError, RuntimeError, TypeError, ValueError) as err:
        raise TrainingError(error) from err
    missing = [key for key in result.missing_keys if not key.startswith(new)]
    if missing or result.unexpected_keys:
        extra = [*missing, *result.unexpected_keys]
        raise TrainingError(f"{error} ({len(extra)} tensors differ, e.g. {extra[0]})")


def _save(model: nn.Module, optimizer: Any, gen: torch.Generator, run: _Run, params: Any) -> None:
    history = run.validator.history if run.validator is not None else []
    state = {
        "model": model.state_dict(),
        "optimizer": optimizer.state_dict(),
        "generator": gen.get_state(),
        "losses": run.losses,
        "step": len(run.losses),
        "elapsed_s": run.elapsed_s,
        "seconds_per_step": _median(run.step_s),
        "validation": json.dumps(history),
    }
    save_checkpoint(params.checkpoint_path, state)


def _median(values: Sequence[float]) -> float:
    return float(np.median(values)) if values else math.nan


def _validator(params: Any, history: Any) -> Any:
    """Return the validator of a segmentation run with dev data, else None."""
    if params.task != "segmentation" or params.val_data is None or params.validate_every <= 0:
        return None
    from superlane_tools.training.validation import (
        PROTOCOL,
        Validator,
        real_dev_sets,
        reference_scores,
    )

    canonical = params.canonical_for(params.input_size)
    sets = real_dev_sets(params.val_data)
    validator = Validator(sets, params.best_path, canonical=canonical)
    if against := getattr(params, "validate_against", None):
        validator.reference = (against, reference_scores(against, sets))
    if isinstance(history, list):  # only entries of this validation protocol compare
        validator.history = [e for e in history if e.get("protocol") == PROTOCOL]
        if validator.history and params.best_path.is_file():  # a clone may hold the checkpoint
            kept = _kept_entry(params.best_path)
            ok = kept is not None and kept.get("protocol") == PROTOCOL
            validator.best = kept if ok else max(validator.history, key=validator.key)
    return validator


def _kept_entry(path: Path) -> dict[str, Any] | None:
    """Return the validation entry stored with the kept weights (None: not readable).

    The kept weights decide, not a recomputation over the history: a resumed run may select by
    another rule (``--validate-against``) than the run that kept them.
    """
    try:
        state = load_checkpoint(path, "best weights", torch.device("cpu"))
        entry = json.loads(str(state.get("validation", "")))
    except (TrainingError, ValueError):
        return None
    return entry if isinstance(entry, dict) and "step" in entry else None


def _step_loss(
    model: nn.Module,
    x: torch.Tensor,
    y: torch.Tensor,
    heads: torch.Tensor,
    params: Any,
    extras: tuple[list[torch.Tensor], list[torch.Tensor | None]],
) -> torch.Tensor:
    luts, class_weights = extras
    if params.task == "segmentation":
        return segmentation_loss(
            model(x),
            head_targets_masked(y, heads, luts),
            HEAD_WEIGHTS,
            class_weights,
            params.marking_dice,
            params.dice_bands,
        )
    assert isinstance(model, EgoCorridorNet | PaperCorridorNet)
    valid = (y != CORRIDOR_IGNORE).unsqueeze(1)
    target = (y == 1).float().unsqueeze(1)
    return corridor_loss(
        model.logits(x),
        target,
        0.0 if params.architecture == "paper" else params.corridor_dice,
        valid,
        rmse=params.architecture == "paper",
    )


def fit(
    model: nn.Module,
    sets: Sequence[LoadedSet],
    params: Any,
    gen: torch.Generator,
    spec: InputSpec,
    progress: Progress | None = None,
    note: Note | None = None,
) -> Fitted:
    """Train ``model`` in place; return the losses, seconds per step and validation summary.

    Args:
        model: The network (moved to ``params.device``).
        sets: The loaded datasets.
        params: The run's :class:`~superlane_tools.training.train.TrainParams`.
        gen: The seeded generator of sampling and augmentation (restored on resume).
        spec: The exported network's input (validation runs it as the runtime does).
        progress: Called after every step.
        note: Called with one-line messages.
    """
    device = torch.device(params.device)
    model.to(device)
    optimizer = _optimizer(model, params)
    base_lrs = [float(g["lr"]) for g in optimizer.param_groups]
    n = sum(len(s.names) for s in sets)
    steps_per_epoch = max(1, -(-n // params.batch))
    total = params.steps or steps_per_epoch * params.epochs
    seg = params.task == "segmentation"
    luts = [torch.from_numpy(head_target_lut(h)).to(device) for h in HEADS]
    class_weights = [
        None if w is None else w.to(device) for w in (_class_weights(sets) if seg else [])
    ]
    probs = torch.tensor([s.spec.weight for s in sets], dtype=torch.float64)
    out_size = params.crop if (seg and params.crop is not None) else params.input_size
    run = _restore(model, optimizer, gen, params, device)
    run.validator = _validator(params, run.validator)
    schedule = Schedule(total, params.budget_s)
    schedule.start(run.elapsed_s)
    say = note or (lambda _text: None)
    if run.first:
        say(f"resumed {params.checkpoint_path} at step {run.first} of {total}")
    mean, std = spec.mean[0], spec.std[0]
    model.train()
    saved_at = time.perf_counter()
    step = run.first
    while not schedule.spent(step) or (step == 0 and schedule.total > 0):  # >= 1 step
        t0 = time.perf_counter()
        schedule.apply(optimizer, base_lrs, step)
        x, y, heads = _batch(sets, probs, params, gen, out_size)
        x, y, heads = ((x - mean) / std).to(device), y.to(device), heads.to(device)
        loss = _step_loss(model, x, y, heads, params, (luts, class_weights))
        optimizer.zero_grad(set_to_none=True)
        loss.backward()  # type: ignore[no-untyped-call]
        optimizer.step()
        value = float(loss.detach())
        if not np.isfinite(value):
            raise TrainingError(f"training diverged at step {step} (loss {value}); lower --lr")
        run.losses.append(value)
        run.step_s.append(time.perf_counter() - t0)
        step += 1
        run.elapsed_s = schedule.elapsed()
        if progress is not None:
            progress(step, total, value)
        if len(run.step_s) == TIMING_STEPS:
            _timing_note(run, step, total, params, say)
        if run.validator is not None and step % params.validate_every == 0:
            _validate(run.validator, model, spec, step, say)
        due_steps = params.checkpoint_every > 0 and step % params.checkpoint_every == 0
        due_time = params.checkpoint_s > 0 and time.perf_counter() - saved_at >= params.checkpoint_s
        if due_steps or due_time or schedule.spent(step):
            _save(model, optimizer, gen, run, params)
            saved_at = time.perf_counter()
    model.eval()
    validation = _final_validation(run, model, spec, step, say)
    epoch_losses = [
        float(np.mean(run.losses[i : i + steps_per_epoch]))
        for i in range(0, len(run.losses), steps_per_epoch)
    ]
    return Fitted(tuple(run.losses), tuple(epoch_losses), _median(run.step_s), validation)


def _timing_note(run: _Run, step: int, total: int, params: Any, say: Note) -> None:
    per_step = _median(run.step_s[1:])
    left = (total - step) * per_step
    say(
        f"{per_step:.2f} s per step (median of steps {step - TIMING_STEPS + 2}-{step}, "
        f"{params.threads} torch threads): {total - step} steps left, about {left / 60:.0f} min"
    )


def _validate(validator: Any, model: nn.Module, spec: InputSpec, step: int, say: Note) -> None:
    entry = validator.run(model, exported_module(model), spec, step)
    scores = ", ".join(f"{k} {v:.3f}" for k, v in entry["scores"].items())
    best = validator.best
    margin = f", worst margin {entry['worst_margin']:+.3f}" if "worst_margin" in entry else ""
    say(
        f"validation at step {step} ({entry['seconds']:.0f} s): {scores}; worst "
        f"{entry['worst_set']} {entry['worst']:.3f}{margin} (best so far: step {best['step']})"
    )


def _final_validation(
    run: _Run, model: nn.Module, spec: InputSpec, step: int, say: Note
) -> dict[str, Any] | None:
    """Validate the last weights unless just done; load the best weights for export."""
    validator = run.validator
    if validator is None or step == 0:
        return None
    if not validator.history or validator.history[-1]["step"] != step:
        _validate(validator, model, spec, step, say)
    best = validator.best
    if best["step"] != step:
        state = load_checkpoint(
            validator.best_path, "best weights", next(model.parameters()).device
        )
        model.load_state_dict(state["model"])
        rule = "worst margin over the reference" if validator.reference else "worst real dev set"
        say(f"exporting the weights of step {best['step']}: best on the {rule}")
    return dict(validator.summary())


def _optimizer(model: nn.Module, params: Any) -> torch.optim.Adam:
    """Adam; a pretrained encoder learns at ``encoder_lr`` x the decoder's rate."""
    if isinstance(model, LiteHierarchicalSegNet):
        groups = [
            {"params": model.encoder_parameters(), "lr": params.lr * params.encoder_lr},
            {"params": model.decoder_parameters(), "lr": params.lr},
        ]
        return torch.optim.Adam(groups, lr=params.lr)
    return torch.optim.Adam(model.parameters(), lr=params.lr)
