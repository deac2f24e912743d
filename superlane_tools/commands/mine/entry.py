"""``slt mine``'s entry: the options as typed, the criteria checked, the mining run."""

from __future__ import annotations

from contextlib import nullcontext
from dataclasses import dataclass, field
from pathlib import Path

from superlane_tools.commands.mine.run import MineResult, mine_runs
from superlane_tools.commands.options import OutputGuard
from superlane_tools.errors import UsageError


@dataclass(frozen=True)
class MineOptions:
    """What ``slt mine`` was asked, as typed (see its options)."""

    inputs: list[Path]
    out: Path
    criteria: str
    require_all: bool = False
    max_frames: int = 50
    max_per_drive: int = 10
    min_gap_s: float = 1.0
    compare_dir: Path | None = None
    recordings: list[Path] = field(default_factory=list)
    command: str = ""
    output_guard: OutputGuard = field(default_factory=nullcontext)


def run(options: MineOptions) -> MineResult:
    """Check the criteria, then pick frames and export them as a label set.

    Raises:
        UsageError: An unknown criterion or a bad limit.
    """
    from superlane_tools.fleet import FleetError
    from superlane_tools.fleet.mining import MineParams

    o = options
    try:
        params = MineParams(
            tuple(c.strip() for c in o.criteria.split(",") if c.strip()),
            o.require_all,
            o.max_frames,
            o.min_gap_s,
            max_per_drive=o.max_per_drive or None,
        )
    except FleetError as err:
        raise UsageError(str(err)) from err
    with o.output_guard:
        return mine_runs(o.inputs, o.out, params, o.recordings, o.compare_dir, o.command)
