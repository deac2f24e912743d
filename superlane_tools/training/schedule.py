"""The learning-rate schedule of a training run: a function of progress, so it survives resume.

Progress is the larger of the step fraction ``step / total`` and, with a wall-clock budget, the
time fraction ``elapsed / budget`` (elapsed time summed over every run of a resumed training).
The factor follows the one-cycle shape over it: a linear warm-up over the first 15 % from 0.04
to 1, then a cosine decay to about 0. Nothing of the schedule is stored in a checkpoint beyond
the step and the elapsed seconds, so a resumed run with more steps or a longer budget rebuilds
it from its own total.
"""

from __future__ import annotations

import math
import time
from typing import Any

WARMUP = 0.15
"""Share of the training spent warming up."""
START_FACTOR = 0.04
"""Learning-rate factor at step 0 (the one-cycle ``1 / div_factor``)."""


class Schedule:
    """Training progress and learning-rate factor of one run (steps and optional budget).

    Args:
        total: Steps in all (this run's target, not the first run's).
        budget_s: Wall-clock budget, seconds, over every run together; None = steps only.
    """

    def __init__(self, total: int, budget_s: float | None) -> None:
        self.total, self.budget_s = total, budget_s
        self.before_s = 0.0
        self.t0 = time.perf_counter()

    def start(self, elapsed_before_s: float = 0.0) -> None:
        """Start the clock; ``elapsed_before_s`` = training seconds of earlier runs (resume)."""
        self.before_s, self.t0 = elapsed_before_s, time.perf_counter()

    def elapsed(self) -> float:
        """Return the training seconds so far, earlier runs included."""
        return self.before_s + time.perf_counter() - self.t0

    def fraction(self, step: int) -> float:
        """Return the share of the training done before ``step``."""
        by_steps = step / self.total
        if self.budget_s is None:
            return by_steps
        return max(by_steps, self.elapsed() / self.budget_s)

    def spent(self, step: int) -> bool:
        """Return True when the step count or the budget is used up."""
        return step >= self.total or (self.budget_s is not None and self.fraction(step) >= 1.0)

    def lr_factor(self, step: int) -> float:
        """Return the learning-rate factor at ``step``."""
        f = min(1.0, self.fraction(step))
        if f < WARMUP:
            return START_FACTOR + (1.0 - START_FACTOR) * f / WARMUP
        return 0.5 * (1.0 + math.cos(math.pi * (f - WARMUP) / (1.0 - WARMUP))) + 1e-4

    def apply(self, optimizer: Any, base_lrs: list[float], step: int) -> None:
        """Set every parameter group's learning rate for ``step``."""
        factor = self.lr_factor(step)
        for group, base in zip(optimizer.param_groups, base_lrs, strict=True):
            group["lr"] = base * factor
