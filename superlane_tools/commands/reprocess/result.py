"""What ``slt reprocess`` returns: its status, files, timings and notes."""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from superlane_tools.records import Skipped

if TYPE_CHECKING:
    import pandas as pd

    from superlane_tools.drive.config import ReprocessConfig
    from superlane_tools.reporting.drive_facts import DriveFacts

Progress = Callable[[int, int | None], None]
"""Progress callback ``(frames done, frames total or None)``."""
Phase = Callable[[str], None]
"""Called with a label when a phase of the run starts (``self-check on 16 frames``, ``pass``,
``report``), so that the progress display says what the time goes to."""


@dataclass(frozen=True)
class ReprocessResult:
    """Outcome of :func:`reprocess`.

    Attributes:
        status: ``ok``, or ``partial`` when input data was lost or skipped.
        skipped: What was lost (reading errors, undecodable frames).
        outputs: Files written.
        timings: Seconds per stage: wall time (``<stage>``, summed over worker threads) and
            thread CPU time (``cpu_<stage>``); ``pass_wall`` / ``post`` / ``total`` wall time of
            the streaming pass, of the tables, plots and report, and of both; ``cpu_pass`` /
            ``cpu_post`` / ``cpu_total`` the process CPU time (all threads) of the same.
        frames: Camera frames processed.
        notes: Missing streams and fallbacks, as stated in the report.
        frames_per_s: Frames per second of wall time, end to end.
        signal_channels: Messages per signal channel added to the annotations
            (``with_signals``; None when none were added).
        implausible: The report's headline warning when no segmentation backend gave
            plausible lanes on the drive (per-drive self-check; "" otherwise).
        availability: Per method that ran, in report order: ``(method, frames, frames
            available, frames whose availability is unknown)`` over the whole drive.
    """

    status: str
    skipped: tuple[Skipped, ...]
    outputs: tuple[Path, ...]
    timings: dict[str, float] = field(default_factory=dict)
    frames: int = 0
    notes: tuple[str, ...] = ()
    frames_per_s: float = 0.0
    signal_channels: dict[str, int] | None = None
    implausible: str = ""
    availability: tuple[tuple[str, int, int, int], ...] = ()


class RunClock:
    """Wall and process CPU time of a run's two phases: the streaming pass and what follows."""

    def __init__(self) -> None:
        self._wall = [time.perf_counter()]
        self._cpu = [time.process_time()]

    def lap(self) -> None:
        """Mark the end of a phase (the pass, then the tables, plots and report)."""
        self._wall.append(time.perf_counter())
        self._cpu.append(time.process_time())

    def pass_timings(self) -> dict[str, float]:
        """Return ``pass_wall`` and ``cpu_pass`` (call after the first lap)."""
        (w0, w1), (c0, c1) = self._wall[:2], self._cpu[:2]
        return {"pass_wall": w1 - w0, "cpu_pass": c1 - c0}

    def timings(self) -> dict[str, float]:
        """Return ``pass_wall``, ``post``, ``total`` and ``cpu_pass``, ``cpu_post``, ``cpu_total``.

        Call after two laps.
        """
        (w0, w1, w2), (c0, c1, c2) = self._wall[:3], self._cpu[:3]
        return {
            "pass_wall": w1 - w0,
            "post": w2 - w1,
            "total": w2 - w0,
            "cpu_pass": c1 - c0,
            "cpu_post": c2 - c1,
            "cpu_total": c2 - c0,
        }


def self_check_label(config: ReprocessConfig, total: int | None) -> str:
    """Return the progress label of the self-check phase (or of stage set-up without one)."""
    from superlane_tools.drive.selfcheck import CLIP_FRAMES, SAMPLE_CLIPS

    seg = config.segmentation
    if seg.backend != "auto" or seg.model:
        return "loading the segmentation model"
    n = SAMPLE_CLIPS * CLIP_FRAMES
    return f"self-check on {min(n, total) if total else n} frames"


def availability_counts(
    sequences: pd.DataFrame, facts: DriveFacts
) -> tuple[tuple[str, int, int, int], ...]:
    """Return ``(method, frames, available, unknown)`` over the drive per method that ran."""
    out = []
    for method in facts.methods_run():
        rows = sequences[sequences["method"] == method] if len(sequences) else sequences
        if not len(rows):
            continue
        sums = [int(rows[c].sum()) for c in ("n_frames", "n_available", "n_unknown")]
        out.append((method, *sums))
    return tuple(out)  # type: ignore[arg-type]
