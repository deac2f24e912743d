"""The sections of ``compare.md`` / ``compare.html``: what differs first, then the verdicts."""

from __future__ import annotations

from collections.abc import Sequence
from datetime import UTC, datetime

import pandas as pd

from superlane_tools.fleet.compare import Comparison
from superlane_tools.fleet.kpis import KPIS
from superlane_tools.fleet.verdicts import GateRule, verdict_table
from superlane_tools.reporting.report import Section


def iso_time(t_ns: int) -> str:
    """Return a log time (ns since the epoch) as ISO 8601 UTC with milliseconds."""
    return datetime.fromtimestamp(t_ns / 1e9, tz=UTC).isoformat(timespec="milliseconds")


def _differences(differences: pd.DataFrame) -> Section:
    if differences.empty:
        lines = ["Nothing: same tool version, same models (SHA-256) and same configuration."]
        return Section("What differs between the runs", lines)
    versions = differences[differences["what"] == "tool version"]
    lines = []
    if not versions.empty:
        row = versions.iloc[0]
        lines.append(
            f"- **Tool versions differ**: base {row['base']}, candidate "
            f"{row['candidate']}; KPI changes may come from the tool, not the model."
        )
    return Section("What differs between the runs", lines, [differences])


def _drives(comparison: Comparison) -> Section:
    lines = [f"- matched drives: {len(comparison.matched)} (same recording and window)"]
    for title, drives in (
        ("only in the base", comparison.only_base),
        ("only in the candidate", comparison.only_candidate),
    ):
        if drives:
            names = ", ".join(d.drive for d in drives)
            lines.append(f"- {title} ({len(drives)}, left out of the deltas): {names}")
    if not comparison.paired:
        lines.append(
            "- no drive matched: the fleets are compared unpaired (each run's "
            "sequences resampled on their own)"
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


def compare_sections(
    comparison: Comparison,
    differences: pd.DataFrame,
    spans: pd.DataFrame,
    regressions: Sequence[str],
    gate: Sequence[GateRule],
    images: Sequence[str],
) -> list[Section]:
    """Return the report sections of a comparison."""
    table = comparison.table
    fleet = comparison.fleet_rows()
    gate_lines = []
    if gate:
        rules = ", ".join(f"{r.pattern}:{r.threshold:g}" for r in gate)
        gate_lines = [f"- release gate ({rules}): " + ("FAILED" if regressions else "passed")]
        gate_lines += [f"- regression: {line}" for line in regressions]
    sections = [
        _differences(differences),
        Section(
            "Fleet verdict",
            [
                f"Candidate - base over the matched sequences; {comparison.params.text()}. "
                "Verdict: better / worse when the interval excludes 0 (frames/s: and the change "
                "reaches 20 % of the base); unavailable: a run has no value (e.g. no truth), "
                "never counted as 0.",
                *gate_lines,
            ],
            [verdict_table(fleet)],
        ),
        _drives(comparison),
    ]
    cats = table[table["scope"] == "category"]
    for category, rows in cats.groupby("category", sort=True):
        sections.append(Section(f"Category {category}", [], [verdict_table(rows)]))
    sections.append(_spans(spans))
    drives = table[table["scope"] == "drive"]
    if not drives.empty:
        verdicts = drives.pivot_table(
            index="drive", columns="kpi", values="verdict", aggfunc="first"
        )
        worse = (verdicts == "worse").sum(axis=1)
        better = (verdicts == "better").sum(axis=1)
        per_drive = pd.DataFrame(
            {
                "drive": verdicts.index,
                "KPIs worse": worse.to_numpy(),
                "KPIs better": better.to_numpy(),
            }
        )
        per_drive = per_drive.sort_values("KPIs worse", ascending=False, kind="stable")
        sections.append(
            Section(
                "Per drive",
                [
                    "KPIs judged worse / better per drive (paired bootstrap over the drive's "
                    "sequences; compare.parquet has every value)."
                ],
                [per_drive],
            )
        )
    if images:
        sections.append(
            Section(
                "Plots",
                [
                    "Per-drive deltas (candidate - base) with their intervals (fleet first; red "
                    "worse, green better); availability of both runs side by side for the drives "
                    "with the worst spans."
                ],
                images=list(images),
            )
        )
    sections.append(
        Section(
            "KPI definitions",
            [
                f"- `{k.name}`: {k.label} ({k.unit}, "
                f"{'higher' if k.higher_is_better else 'lower'}"
                " is better)"
                for k in KPIS
            ],
        )
    )
    return sections
