"""The sections of ``compare.md`` / ``compare.html``: what differs first, then the verdicts."""

from __future__ import annotations

from collections.abc import Sequence
from datetime import UTC, datetime

import numpy as np
import pandas as pd

from superlane_tools.errors import ExitCode
from superlane_tools.fleet.compare import Comparison
from superlane_tools.fleet.differences import difference_lines
from superlane_tools.fleet.kpis import KPIS
from superlane_tools.fleet.verdicts import PRIMARY_KPIS, GateResult, verdict_margin, verdict_table
from superlane_tools.reporting.report import Section


def iso_time(t_ns: int) -> str:
    """Return a log time (ns since the epoch) as ISO 8601 UTC with milliseconds."""
    return datetime.fromtimestamp(t_ns / 1e9, tz=UTC).isoformat(timespec="milliseconds")


MULTIPLE_COMPARISONS = (
    "Each KPI's interval misses the true change 5 % of the time, so among 20 unchanged KPIs "
    "about one will look better or worse by chance; the verdicts are per KPI, and only the gate "
    "corrects for the number of KPIs (Holm). Gate on a few primary KPIs ("
    + ", ".join(f"`{k}`" for k in PRIMARY_KPIS)
    + ") rather than `all`: each gated KPI costs power."
)


def _counts(comparison: Comparison) -> str:
    matched, n_b, n_c = comparison.n_drives()
    seqs, s_b, s_c = comparison.sequences
    return (
        f"- matched: {matched} of {n_b} base and {n_c} candidate drives; {seqs} of {s_b} base "
        f"and {s_c} candidate sequences"
    )


def _differences(comparison: Comparison, differences: pd.DataFrame) -> Section:
    lines = [_counts(comparison)]
    shown = difference_lines(differences)
    if not shown:
        lines.append(
            "- nothing else differs: same tool version, backend, models (SHA-256) and configuration"
        )
    lines += [f"- {line}" for line in shown]
    versions = differences[differences["what"] == "tool version"]
    if not versions.empty:
        lines.append(
            "- the tool versions differ: KPI changes may come from the tool, not the model"
        )
    return Section("What differs between the runs", lines)


def _drives(comparison: Comparison) -> Section:
    lines = [_counts(comparison) + " (drives: same recording and window)"]
    for title, drives in (
        ("only in the base", comparison.only_base),
        ("only in the candidate", comparison.only_candidate),
    ):
        if drives:
            names = ", ".join(d.drive for d in drives)
            lines.append(f"- {title} ({len(drives)}, left out of the deltas): {names}")
    if comparison.unaligned:
        names = ", ".join(b.drive for b, _ in comparison.unaligned)
        lines.append(
            f"- same recording, no sequence lines up ({len(comparison.unaligned)}, left out; "
            f"another kpi.window_s?): {names}"
        )
    if not comparison.paired:
        lines.append(
            "- no drive matched: both fleets' values are shown side by side, without intervals "
            "or verdicts"
        )
    return Section("Drives", lines)


def _spans(spans: pd.DataFrame) -> Section:
    lines = [
        "Time ranges where the two runs differ most (per frame: availability flips, SUPER lane "
        "width and curvature changes). Open both runs' annotations MCAP in Foxglove (File > "
        "Open, select both files) and seek to the start time.",
    ]
    if spans.empty:
        return Section("Worst disagreement spans", [*lines, "- none: the runs agree"])
    table = pd.DataFrame(
        {
            "drive": spans["drive"],
            "recording": spans["recording"],
            "start (UTC)": [iso_time(int(t)) for t in spans["start_ns"]],
            "start_s": spans["start_s"],
            "duration_s": spans["duration_s"],
            "frames": [
                f"{a}-{b}" for a, b in zip(spans["first_frame"], spans["last_frame"], strict=True)
            ],
            "main difference": spans["main_difference"],
            "score": spans["score"],
            "base annotations": spans["base_annotations"],
            "candidate annotations": spans["candidate_annotations"],
        }
    )
    return Section("Worst disagreement spans", lines, [table])


def _gate_lines(gate: GateResult | None) -> list[str]:
    if gate is None or (not gate.gated and gate.code == ExitCode.OK):
        return []
    outcome = {ExitCode.OK: "passed", ExitCode.REGRESSION: "FAILED"}.get(gate.code, "CANNOT DECIDE")
    lines = [f"- **release gate: {outcome}** ({gate.statement})"]
    lines += [f"- regression: {line}" for line in gate.regressions]
    return lines + [f"- cannot decide: {line}" for line in gate.undecided]


def _per_drive(table: pd.DataFrame) -> Section | None:
    drives = table[table["scope"] == "drive"]
    if drives.empty:
        return None
    sign = np.where(drives["higher_is_better"].astype(bool), 1.0, -1.0)
    change = sign * drives["delta"].to_numpy(np.float64)
    margin = drives["margin"].to_numpy(np.float64)
    frame = pd.DataFrame(
        {
            "drive": drives["drive"].to_numpy(),
            "worse": change < -margin,
            "better": change > margin,
        }
    )
    counts = frame.groupby("drive", sort=False)[["worse", "better"]].sum()
    per_drive = pd.DataFrame(
        {
            "drive": counts.index,
            "KPIs worse by more than the margin": counts["worse"].to_numpy(),
            "KPIs better by more than the margin": counts["better"].to_numpy(),
        }
    ).sort_values("KPIs worse by more than the margin", ascending=False, kind="stable")
    return Section(
        "Per drive (descriptive)",
        [
            "One drive's change has no interval (its sequences share road, weather and the "
            "tracker's state): these counts say where to look, not what is significant "
            "(compare.parquet has every value)."
        ],
        [per_drive],
    )


def _definitions(comparison: Comparison) -> Section:
    lines = []
    for k in KPIS:
        margin = (
            f"{k.relative_margin:.0%} of the base"
            if k.relative_margin
            else verdict_margin(comparison.margins.get(k.name, k.margin), k.unit)
        )
        better = "higher" if k.higher_is_better else "lower"
        lines.append(f"- `{k.name}`: {k.label} ({k.unit}, {better} is better; margin {margin})")
    return Section("KPI definitions", lines)


def compare_sections(
    comparison: Comparison,
    differences: pd.DataFrame,
    spans: pd.DataFrame,
    gate: GateResult | None,
    images: Sequence[str],
) -> list[Section]:
    """Return the report sections of a comparison."""
    table = comparison.table
    fleet = comparison.fleet_rows()
    sections = [
        _differences(comparison, differences),
        Section(
            "Fleet verdict",
            [
                *_gate_lines(gate),
                "",
                f"Candidate - base over the matched drives; {comparison.params.text()}. "
                "Verdict: better / worse when the interval excludes 0 and leaves the margin, "
                "equivalent when it lies inside +-margin, inconclusive otherwise; too few "
                "drives below the minimum; unavailable: the base has no value (e.g. no truth), "
                "never counted as 0; lost: the base measured it, the candidate on no drive.",
                "",
                MULTIPLE_COMPARISONS,
            ],
            [verdict_table(fleet)],
        ),
        _drives(comparison),
    ]
    cats = table[table["scope"] == "category"]
    for category, rows in cats.groupby("category", sort=True):
        sections.append(Section(f"Category {category}", [], [verdict_table(rows)]))
    sections.append(_spans(spans))
    per_drive = _per_drive(table)
    if per_drive is not None:
        sections.append(per_drive)
    if images:
        sections.append(
            Section(
                "Plots",
                [
                    "Per-drive deltas (candidate - base, descriptive) beside the fleet's with its "
                    "interval (red worse, green better); availability of both runs side by side "
                    "for the drives with the worst spans."
                ],
                images=list(images),
            )
        )
    sections.append(_definitions(comparison))
    folded = differences[differences["folded"].astype(bool)]
    if not folded.empty:
        sections.append(Section("Self-check details", [], [folded[["key", "base", "candidate"]]]))
    return sections
