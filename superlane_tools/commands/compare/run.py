"""``slt compare BASE CANDIDATE``: read both fleets' tables, compare, write tables and report."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import pandas as pd

from superlane_tools.fleet import (
    BootstrapParams,
    Comparison,
    DriveKpis,
    DriveRun,
    FleetError,
    GateResult,
    GateRule,
    SpanParams,
    compare_fleets,
    compare_sections,
    disagreement_spans,
    find_drives,
    frame_disagreement,
    judge_gate,
    read_tables,
    run_differences,
    sequence_kpis,
)
from superlane_tools.records import Skipped
from superlane_tools.reporting import Provenance, write_table
from superlane_tools.reporting.layout import COMPARE_DRIVES_TABLE, CompareLayout
from superlane_tools.reporting.report import write_report

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


def _read(
    base: tuple[DriveRun, ...], candidate: tuple[DriveRun, ...], params: SpanParams
) -> tuple[list[DriveKpis], list[DriveKpis], pd.DataFrame]:
    """Read every drive's tables once: its sequence KPIs, and the spans of matched drives."""
    others = {d.key: d for d in candidate}
    kb, kc, parts = [], [], []
    for drive in base:
        tables = read_tables(drive)
        cand = others.pop(drive.key, None)
        if cand is None:
            kb.append((drive, sequence_kpis(tables)))
            continue
        cand_tables = read_tables(cand)  # conditional KPIs: on frames both runs produced
        kb.append((drive, sequence_kpis(tables, cand_tables)))
        kc.append((cand, sequence_kpis(cand_tables, tables)))
        spans = disagreement_spans(
            drive.drive, frame_disagreement(tables, cand_tables, params), params
        )
        parts.append(
            spans.assign(
                recording=drive.recording,
                base_annotations=str(drive.annotations),
                candidate_annotations=str(cand.annotations),
            )
        )
    kc += [(d, sequence_kpis(read_tables(d))) for d in others.values()]
    if not parts:
        return kb, kc, pd.DataFrame()
    spans = pd.concat(parts, ignore_index=True).sort_values("score", ascending=False)
    return kb, kc, spans.head(params.max_spans).reset_index(drop=True)


def _plots(out: Path, result: CompareResult, params: CompareParams) -> list[Path]:
    from superlane_tools.reporting.compare_plots import plot_deltas, plot_timelines

    layout = CompareLayout(out)
    pngs = [plot_deltas(result.comparison.table, DELTA_PLOT_KPIS, layout.deltas_plot())]
    pairs = (*result.comparison.matched, *result.comparison.unaligned)
    matched = {b.drive: (b, c) for b, c in pairs}
    worst = list(dict.fromkeys(result.spans["drive"])) if not result.spans.empty else []
    for k, drive in enumerate(worst[: params.timelines]):
        base, cand = matched[drive]
        pngs.append(
            plot_timelines(
                drive,
                read_tables(base).availability_frames,
                read_tables(cand).availability_frames,
                result.spans[result.spans["drive"] == drive],
                layout.timeline_plot(k),
            )
        )
    return pngs


def compare_runs(base: Path, candidate: Path, out: Path, params: CompareParams) -> CompareResult:
    """Compare a candidate run (folder or batch root) with a base one; write the outputs to ``out``.

    Raises:
        FleetError: If an input is not a run or batch root, a fleet has no drive, or tables of
            a run are incompatible with this tool version.
    """
    fleets = find_drives(base), find_drives(candidate)
    for fleet in fleets:
        if not fleet.drives:
            raise FleetError(f"{fleet.root}: empty fleet: no drive with a reprocess run")
    differences = run_differences(fleets[0].drives, fleets[1].drives)
    kpis_base, kpis_cand, spans = _read(fleets[0].drives, fleets[1].drives, params.spans)
    comparison = compare_fleets(kpis_base, kpis_cand, params.bootstrap, params.margins)
    skipped = [*fleets[0].skipped, *fleets[1].skipped]
    skipped += [Skipped("drive only in the base", d.drive) for d in comparison.only_base]
    skipped += [Skipped("drive only in the candidate", d.drive) for d in comparison.only_candidate]
    skipped += [
        Skipped("drive whose sequences do not line up", b.drive) for b, _ in comparison.unaligned
    ]
    result = CompareResult(
        comparison, differences, spans, judge_gate(comparison, params.gate), tuple(skipped)
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
        write_table(_drives(comparison), layout.drives, provenance),
    ]
    images = _plots(out, result, params) if params.plots else []
    written += images
    title = f"slt compare: {candidate.name} (candidate) against {base.name} (base)"
    sections = compare_sections(
        comparison,
        differences,
        result.spans,
        result.gate if params.gate else None,
        [p.relative_to(out).as_posix() for p in images],
    )
    written += write_report(layout.report, title, sections)
    return CompareResult(
        result.comparison,
        differences,
        result.spans,
        result.gate,
        result.skipped,
        tuple(written),
    )


def _drives(comparison: Comparison) -> pd.DataFrame:
    rows: list[tuple[str, DriveRun, Path | None, Path | None]]
    rows = [("matched", b, b.folder, c.folder) for b, c in comparison.matched]
    rows += [("only in the base", b, b.folder, None) for b in comparison.only_base]
    rows += [("only in the candidate", c, None, c.folder) for c in comparison.only_candidate]
    rows += [("sequences do not line up", b, b.folder, c.folder) for b, c in comparison.unaligned]
    columns = list(COMPARE_DRIVES_TABLE.columns)
    return pd.DataFrame(
        [
            (d.drive, status, d.recording, d.category, str(fb or ""), str(fc or ""))
            for status, d, fb, fc in rows
        ],
        columns=columns,
    )
