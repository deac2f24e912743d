"""What ``slt reprocess`` returns: its status, files, timings and notes."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from superlane_tools.records import Skipped


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
