"""Two fleets read once for a comparison: their drives, sequence KPIs and disagreement spans.

:func:`load` is the fleet layer's one verb for ``slt compare``'s reading: it finds both fleets'
drives, reads every drive's tables once, computes each drive's sequence KPIs (conditional on
the frames both runs produced when the drive is in both fleets) and the spans where the two
runs of a drive disagree, and keeps the per-frame availability of the drives with the worst
spans for their timeline plots.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import pandas as pd

from superlane_tools.fleet.compare import Comparison, DriveKpis
from superlane_tools.fleet.differences import run_differences
from superlane_tools.fleet.errors import FleetError
from superlane_tools.fleet.kpis import sequence_kpis
from superlane_tools.fleet.runs import DriveRun, Fleet, find_drives, read_tables
from superlane_tools.fleet.spans import SpanParams, disagreement_spans, frame_disagreement
from superlane_tools.records import Skipped
from superlane_tools.reporting.layout import COMPARE_DRIVES_TABLE


@dataclass(frozen=True)
class LoadedFleets:
    """Both fleets, read once.

    Attributes:
        base: The base fleet's drives and what was skipped finding them.
        candidate: The candidate fleet's.
        differences: How the two fleets' runs differ (tool, model, configuration).
        kpis_base: Per base drive, its sequence KPIs.
        kpis_candidate: Per candidate drive, its sequence KPIs.
        spans: The disagreement spans of the drives in both fleets, worst first (at most
            ``SpanParams.max_spans``).
        timelines: Drive -> the base's and the candidate's ``availability_frames``, for the
            first ``timelines`` drives of :attr:`spans` (their timeline plots).
    """

    base: Fleet
    candidate: Fleet
    differences: pd.DataFrame
    kpis_base: list[DriveKpis]
    kpis_candidate: list[DriveKpis]
    spans: pd.DataFrame
    timelines: dict[str, tuple[pd.DataFrame, pd.DataFrame]] = field(default_factory=dict)

    def skipped(self, comparison: Comparison) -> tuple[Skipped, ...]:
        """Return what finding the drives skipped, and the drives the comparison left out."""
        out = [*self.base.skipped, *self.candidate.skipped]
        out += [Skipped("drive only in the base", d.drive) for d in comparison.only_base]
        out += [Skipped("drive only in the candidate", d.drive) for d in comparison.only_candidate]
        out += [
            Skipped("drive whose sequences do not line up", b.drive)
            for b, _ in comparison.unaligned
        ]
        return tuple(out)


def load(base: Path, candidate: Path, spans: SpanParams, timelines: int = 0) -> LoadedFleets:
    """Read a base and a candidate fleet (run folders or batch roots) once.

    Args:
        base: The base run folder, folder of runs or batch root.
        candidate: The candidate's.
        spans: How disagreement spans are found and how many are kept.
        timelines: Keep the per-frame availability of this many worst drives (for plots).

    Raises:
        FleetError: If an input is not a run or batch root, a fleet has no drive, or tables of
            a run are incompatible with this tool version.
    """
    fleets = find_drives(base), find_drives(candidate)
    for fleet in fleets:
        if not fleet.drives:
            raise FleetError(f"{fleet.root}: empty fleet: no drive with a reprocess run")
    others = {d.key: d for d in fleets[1].drives}
    kb: list[DriveKpis] = []
    kc: list[DriveKpis] = []
    parts: list[pd.DataFrame] = []
    frames: dict[str, tuple[pd.DataFrame, pd.DataFrame]] = {}
    for drive in fleets[0].drives:
        tables = read_tables(drive)
        cand = others.pop(drive.key, None)
        if cand is None:
            kb.append((drive, sequence_kpis(tables)))
            continue
        cand_tables = read_tables(cand)  # conditional KPIs: on frames both runs produced
        kb.append((drive, sequence_kpis(tables, cand_tables)))
        kc.append((cand, sequence_kpis(cand_tables, tables)))
        found = disagreement_spans(
            drive.drive, frame_disagreement(tables, cand_tables, spans), spans
        )
        if timelines > 0 and not found.empty:
            frames[drive.drive] = (tables.availability_frames, cand_tables.availability_frames)
        parts.append(_with_runs(found, drive, cand))
    kc += [(d, sequence_kpis(read_tables(d))) for d in others.values()]
    worst = _worst(parts, spans.max_spans)
    kept = list(dict.fromkeys(worst["drive"]))[:timelines] if not worst.empty else []
    return LoadedFleets(
        *fleets,
        run_differences(fleets[0].drives, fleets[1].drives),
        kb,
        kc,
        worst,
        {name: frames[name] for name in kept},
    )


def _with_runs(spans: pd.DataFrame, base: DriveRun, candidate: DriveRun) -> pd.DataFrame:
    """Return a drive's spans with its recording and both runs' annotations (for ``mine``)."""
    return spans.assign(
        recording=base.recording,
        base_annotations=str(base.annotations),
        candidate_annotations=str(candidate.annotations),
    )


def _worst(parts: list[pd.DataFrame], max_spans: int) -> pd.DataFrame:
    """Return every drive's spans, worst first, at most ``max_spans``."""
    if not parts:
        return pd.DataFrame()
    spans = pd.concat(parts, ignore_index=True).sort_values("score", ascending=False)
    return spans.head(max_spans).reset_index(drop=True)


def drives_table(comparison: Comparison) -> pd.DataFrame:
    """Return one row per drive of either fleet: how the comparison treated it, its run folders."""
    rows: list[tuple[str, DriveRun, Path | None, Path | None]]
    rows = [("matched", b, b.folder, c.folder) for b, c in comparison.matched]
    rows += [("only in the base", b, b.folder, None) for b in comparison.only_base]
    rows += [("only in the candidate", c, None, c.folder) for c in comparison.only_candidate]
    rows += [("sequences do not line up", b, b.folder, c.folder) for b, c in comparison.unaligned]
    return pd.DataFrame(
        [
            (d.drive, status, d.recording, d.category, str(fb or ""), str(fc or ""))
            for status, d, fb, fc in rows
        ],
        columns=list(COMPARE_DRIVES_TABLE.columns),
    )
