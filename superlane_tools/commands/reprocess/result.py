"""What ``slt reprocess`` returns: its status, files, timings and notes."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from superlane_tools.records import Skipped

Progress = Callable[[int, int | None], None]
"""Progress callback ``(frames done, frames total or None)``."""


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
    """

    status: str
    skipped: tuple[Skipped, ...]
    outputs: tuple[Path, ...]
    timings: dict[str, float] = field(default_factory=dict)
    frames: int = 0
    notes: tuple[str, ...] = ()
    frames_per_s: float = 0.0
