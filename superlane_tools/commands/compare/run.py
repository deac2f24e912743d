"""``slt compare BASE CANDIDATE``: read both fleets' tables, compare, write tables and report."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING

from superlane_tools.fleet import (
    BootstrapParams,
    Comparison,
    GateResult,
    GateRule,
    LoadedFleets,
    SpanParams,
    compare_fleets,
    compare_sections,
    drives_table,
    judge_gate,
    load,
)
from superlane_tools.records import Skipped
from superlane_tools.reporting import Provenance, write_table
from superlane_tools.reporting.layout import CompareLayout
from superlane_tools.reporting.report import write_report

if TYPE_CHECKING:
    import pandas as pd

DELTA_PLOT_KPIS = (
    "availability_frames.super",
    "curvature_rmse_truth.super_path",
    "lane_width_bias",
    "coverage.fit",
)
"""KPIs of the per-drive delta plot."""


@dataclass(frozen=True)
class CompareParams:
    """Settings of one comparison (intervals, margins, spans, the release gate, plots)."""

    bootstrap: BootstrapParams = field(default_factory=BootstrapParams)
    margins: Mapping[str, float] = field(default_factory=dict)
    spans: SpanParams = field(default_factory=SpanParams)
    gate: tuple[GateRule, ...] = ()
    plots: bool = True
    timelines: int = 3
    command: str = ""


@dataclass(frozen=True)
class CompareResult:
    """What a comparison found and wrote."""

    comparison: Comparison
    differences: pd.DataFrame
    spans: pd.DataFrame
    gate: GateResult
    skipped: tuple[Skipped, ...]
    outputs: tuple[Path, ...] = field(default=())

    @property
    def regressions(self) -> tuple[str, ...]:
        """Return the gate's regression lines (exit 4)."""
        return self.gate.regressions


def _plots(layout: CompareLayout, result: CompareResult, fleets: LoadedFleets) -> list[Path]:
    from superlane_tools.reporting.compare_plots import plot_deltas, plot_timelines

    pngs = [plot_deltas(result.comparison.table, DELTA_PLOT_KPIS, layout.deltas_plot())]
    for k, (drive, (base, candidate)) in enumerate(fleets.timelines.items()):
        spans = result.spans[result.spans["drive"] == drive]
        pngs.append(plot_timelines(drive, base, candidate, spans, layout.timeline_plot(k)))
    return pngs


def compare_runs(base: Path, candidate: Path, out: Path, params: CompareParams) -> CompareResult:
    """Compare a candidate run (folder or batch root) with a base one; write the outputs to ``out``.

    Raises:
        FleetError: If an input is not a run or batch root, a fleet has no drive, or tables of
            a run are incompatible with this tool version.
    """
    fleets = load(base, candidate, params.spans, params.timelines if params.plots else 0)
    comparison = compare_fleets(
        fleets.kpis_base, fleets.kpis_candidate, params.bootstrap, params.margins
    )
    gate = judge_gate(comparison, params.gate)
    result = CompareResult(
        comparison, fleets.differences, fleets.spans, gate, fleets.skipped(comparison)
    )
    provenance = Provenance(
        command=params.command or "slt compare",
        config={
            "base": str(base),
            "candidate": str(candidate),
            "bootstrap": params.bootstrap.text(),
            "margins": dict(comparison.margins),
            "gate": [r.text() for r in params.gate],
        },
    )
    layout = CompareLayout(out)
    written = [
        write_table(comparison.table, layout.compare, provenance),
        write_table(result.spans, layout.spans, provenance),
        write_table(drives_table(comparison), layout.drives, provenance),
    ]
    images = _plots(layout, result, fleets) if params.plots else []
    sections = compare_sections(
        comparison,
        result.differences,
        result.spans,
        gate if params.gate else None,
        [p.relative_to(out).as_posix() for p in images],
    )
    title = f"slt compare: {candidate.name} (candidate) against {base.name} (base)"
    written += [*images, *write_report(layout.report, title, sections)]
    return replace(result, outputs=tuple(written))
