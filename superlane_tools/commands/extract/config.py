"""What ``slt extract`` takes (:class:`ExtractConfig`, validated) and returns."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

from superlane_tools.can import Coverage
from superlane_tools.errors import ConfigError, UsageError
from superlane_tools.geo import GeodeticOrigin
from superlane_tools.recording import STREAM_KINDS
from superlane_tools.records import Skipped

MAX_OFFSET_S = 9e9
"""Largest --start/--end offset, seconds (int64 ns holds 292 years)."""
FRAME_FORMATS = ("jpg", "png", "none")


@dataclass(frozen=True)
class ExtractConfig:
    """What to extract and how.

    Attributes:
        topics: Restrict to these topics (streams still found by message type); empty: all.
        streams: Explicit topic lists per kind (``frames``, ``camera_info``, ``can``, ``gnss``),
            e.g. from a YAML config; a kind listed here is not auto-detected.
        start_s: Start of the range, seconds after the recording's first message; None: start.
        end_s: End of the range (exclusive), seconds after the first message; None: end.
        start_ns: Start as an absolute log time, ns (overrides ``start_s``).
        end_ns: End (exclusive) as an absolute log time, ns (overrides ``end_s``).
        dbc_paths: DBC files to decode CAN frames with (none: raw frames only); ``BUS=FILE``
            binds a DBC to one bus (CAN topic or channel), a plain file applies to all.
        frame_format: ``jpg``, ``png`` (files) or ``none`` (index only).
        every: Keep every Nth frame of each image topic.
        origin: ENU origin; None: the first valid fix.
    """

    topics: tuple[str, ...] = ()
    streams: Mapping[str, tuple[str, ...]] = field(default_factory=dict)
    start_s: float | None = None
    end_s: float | None = None
    start_ns: int | None = None
    end_ns: int | None = None
    dbc_paths: tuple[Path, ...] = ()
    frame_format: str = "jpg"
    every: int = 1
    origin: GeodeticOrigin | None = None

    def __post_init__(self) -> None:
        if self.frame_format not in FRAME_FORMATS:
            raise UsageError(
                f"frame format must be one of {FRAME_FORMATS}, not {self.frame_format!r}"
            )
        if self.every < 1:
            raise UsageError(f"--every must be >= 1, got {self.every}")
        for name, value in (("--start", self.start_s), ("--end", self.end_s)):
            if value is not None and not (math.isfinite(value) and abs(value) <= MAX_OFFSET_S):
                raise UsageError(f"{name} must be a finite number of seconds, got {value}")
        if self.start_s is not None and self.start_s < 0:
            raise UsageError(f"--start must be >= 0 s, got {self.start_s}")
        if self.end_s is not None and self.end_s <= (self.start_s or 0.0):
            start = self.start_s or 0.0
            raise UsageError(f"--end ({self.end_s} s) must be after --start ({start} s)")
        unknown = set(self.streams) - set(STREAM_KINDS)
        if unknown:
            raise ConfigError(f"unknown stream kinds {sorted(unknown)}: use {STREAM_KINDS}")


@dataclass(frozen=True)
class ExtractResult:
    """What an extraction produced.

    Attributes:
        outputs: Files written (Parquet tables; image files are listed in ``frames.parquet``).
        selected: Kind -> topics extracted.
        counts: Kind -> rows written (frames indexed, CAN frames, signal rows, fixes).
        dbc_repairs: DBC file name -> repairs made while loading it.
        skipped: What was skipped or lost (reading errors, corrupt frames), one entry per kind.
        origin: The ENU origin used, when GNSS was extracted.
        can_coverage: Ids matched by the DBCs of the ids seen (None without CAN or DBCs).
    """

    outputs: tuple[Path, ...]
    selected: Mapping[str, tuple[str, ...]]
    counts: Mapping[str, int]
    dbc_repairs: Mapping[str, list[str]]
    skipped: tuple[Skipped, ...]
    origin: GeodeticOrigin | None
    can_coverage: Coverage | None = None
