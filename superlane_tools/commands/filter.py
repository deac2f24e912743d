"""`slt filter`: a trimmed copy of a recording (topics, time range), same format."""

from __future__ import annotations

from contextlib import AbstractContextManager, nullcontext
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from superlane_tools.recording._filter_types import FilterResult


@dataclass(frozen=True)
class FilterParams:
    """What ``slt filter`` was asked.

    Attributes:
        recording: The recording (MCAP, ROS 1 bag, ROS 2 bag).
        out: The trimmed copy (``.mcap``, ``.bag`` or a ROS 2 bag folder).
        topics: Keep topics matching any of these regular expressions (none: every one).
        exclude: Drop topics matching any of these regular expressions.
        start: Start time (``parse_time`` syntax), or None.
        end: End time (exclusive), or None.
        output_guard: Entered around the writing (the cli's policy for an existing output).
    """

    recording: Path
    out: Path
    topics: tuple[str, ...] = ()
    exclude: tuple[str, ...] = ()
    start: str | None = None
    end: str | None = None
    output_guard: AbstractContextManager[object] = field(default_factory=nullcontext)


def run(params: FilterParams) -> FilterResult:
    """Write the trimmed copy; return what it holds."""
    from superlane_tools.recording.tools import filter_recording

    p = params
    with p.output_guard:
        return filter_recording(p.recording, p.out, p.topics, p.exclude, p.start, p.end)
