"""``slt compare``'s entry: the options as typed, the comparison, the summary the cli prints."""

from __future__ import annotations

from contextlib import nullcontext
from dataclasses import dataclass, field
from pathlib import Path

from superlane_tools.commands.compare.run import CompareParams, compare_runs
from superlane_tools.commands.options import OutputGuard
from superlane_tools.errors import ExitCode, UsageError
from superlane_tools.records import Skipped

SHOWN_DIFFERENCES = 5
"""Differences between the two runs' settings printed (every one is in compare.md)."""


def check_rule(text: str) -> None:
    """Parse a ``--fail-on-regression KPI[:MARGIN]`` value; raise ``UsageError`` if bad."""
    from superlane_tools.fleet import parse_rule

    parse_rule(text)


def parse_margin(text: str) -> tuple[str, float]:
    """Parse ``KPI=VALUE`` (display unit: percentage points for ratios) into the KPI's unit."""
    from superlane_tools.fleet import KPI_BY_NAME

    name, _, value = text.partition("=")
    if name not in KPI_BY_NAME:
        raise UsageError(f"--margin {text}: unknown KPI {name!r} (names as in compare.md)")
    try:
        margin = float(value)
    except ValueError:
        margin = float("nan")
    if not margin >= 0:
        raise UsageError(f"--margin {text}: expected KPI=VALUE with a number >= 0")
    return name, margin / 100.0 if KPI_BY_NAME[name].unit == "ratio" else margin


@dataclass(frozen=True)
class CompareOptions:
    """What ``slt compare`` was asked, as typed (see its options)."""

    base: Path
    candidate: Path
    out: Path
    gate: list[str] = field(default_factory=list)
    margins: list[str] = field(default_factory=list)
    seed: int = 0
    resamples: int = 2000
    spans: int = 10
    plots: bool = True
    command: str = ""
    output_guard: OutputGuard = field(default_factory=nullcontext)


@dataclass(frozen=True)
class CompareSummary:
    """What the cli prints of a comparison.

    Attributes:
        differences: The first lines of how the two runs' settings differ.
        drives: Matched drives, base drives, candidate drives.
        verdicts: Fleet KPIs ``worse``, ``better`` and ``other``.
        skipped: What could not be read.
        regressions: The gate's regression lines (exit 4).
        undecided: Why the gate cannot decide (exit 3).
        gate_code: The gate's exit code.
    """

    differences: list[str]
    drives: tuple[int, int, int]
    verdicts: dict[str, int]
    skipped: tuple[Skipped, ...]
    regressions: tuple[str, ...]
    undecided: tuple[str, ...]
    gate_code: ExitCode


def run(options: CompareOptions) -> CompareSummary:
    """Compare the candidate with the base, write the outputs, summarise for printing."""
    from superlane_tools.fleet import BootstrapParams, SpanParams, difference_lines, parse_rule

    o = options
    params = CompareParams(
        bootstrap=BootstrapParams(n_resamples=o.resamples, seed=o.seed),
        margins=dict(parse_margin(v) for v in o.margins),
        spans=SpanParams(max_spans=o.spans),
        gate=tuple(parse_rule(v) for v in o.gate),
        plots=o.plots,
        command=o.command,
    )
    with o.output_guard:
        result = compare_runs(o.base, o.candidate, o.out, params)
    fleet = result.comparison.fleet_rows()
    counts = fleet["verdict"].value_counts()
    worse, better = int(counts.get("worse", 0)), int(counts.get("better", 0))
    return CompareSummary(
        differences=difference_lines(result.differences)[:SHOWN_DIFFERENCES],
        drives=result.comparison.n_drives(),
        verdicts={"worse": worse, "better": better, "other": len(fleet) - worse - better},
        skipped=result.skipped,
        regressions=tuple(result.gate.regressions),
        undecided=tuple(result.gate.undecided),
        gate_code=result.gate.code,
    )
