"""The sections of ``slt history``'s page: drifts first, model and config changes, each KPI."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import pandas as pd

from superlane_tools.fleet.drift import CUSUM_SLACK, DECLINE_STEPS
from superlane_tools.fleet.kpis import KPI_BY_NAME
from superlane_tools.reporting.report import Section

QUERY_EXAMPLE = """```
import duckdb   # pip install 'superlane-tools[history]'
duckdb.sql("SELECT night, kpi, value, ci_low, ci_high, verdict, model "
           "FROM read_parquet('ROOT/history/*/*.parquet', hive_partitioning = true) "
           "WHERE kpi = 'availability_frames.super' ORDER BY night").df()

import pandas as pd
history = pd.read_parquet("ROOT/history")   # the night comes back from the partitions
```"""


def format_value(kpi: str, value: float) -> str:
    """Return a KPI value for the page: ratios in %, others to 3 significant digits."""
    if not np.isfinite(value):
        return "n/a"
    spec = KPI_BY_NAME.get(kpi)
    if spec is not None and spec.unit == "ratio":
        return f"{100 * value:.1f}%"
    return f"{value:.3g} {spec.unit if spec is not None else ''}".strip()


def format_change(kpi: str, change: float) -> str:
    """Return a change of a KPI: percentage points for ratios, else the KPI's unit."""
    spec = KPI_BY_NAME.get(kpi)
    if spec is not None and spec.unit == "ratio":
        return f"{100 * change:+.1f} pp"
    return f"{change:+.3g} {spec.unit if spec is not None else ''}".strip()


def drift_line(row: Mapping[Any, Any]) -> str:
    """Return one drift alarm as one line (what, how much, when, which rule, caught or not)."""
    kpi = str(row["kpi"])
    first, last = float(row["first_value"]), float(row["last_value"])
    caught = (
        f"caught by the gate on {row['caught_by']}"
        if row["caught"]
        else "no night's gate caught it"
    )
    return (
        f"{kpi}: {format_value(kpi, first)} -> {format_value(kpi, last)} "
        f"({format_change(kpi, last - first)}) over {row['nights']} nights, "
        f"{row['first_night']} to {row['last_night']} (rule {row['rule']}, margin "
        f"{format_change(kpi, float(row['margin'])).lstrip('+')}): {caught}"
    )


def _changes_table(
    model_changes: Sequence[tuple[str, str, str]], config_changes: Sequence[tuple[str, str, str]]
) -> pd.DataFrame:
    rows = [(n, "model", b, a) for n, b, a in model_changes]
    rows += [(n, "config id", b, a) for n, b, a in config_changes]
    return pd.DataFrame(sorted(rows), columns=["night", "change", "before", "after"])


def _kpi_table(series: pd.DataFrame, kpi: str) -> pd.DataFrame:
    rows = series[series["kpi"] == kpi].sort_values("night")
    interval = [
        f"[{format_change(kpi, lo)}, {format_change(kpi, hi)}]"
        if np.isfinite(lo) and np.isfinite(hi)
        else "-"
        for lo, hi in zip(rows["ci_low"].astype(float), rows["ci_high"].astype(float), strict=True)
    ]
    return pd.DataFrame(
        {
            "night": rows["night"],
            "value": [format_value(kpi, v) for v in rows["value"].astype(float)],
            "change vs baseline": [
                format_change(kpi, d) if np.isfinite(d) else "-"
                for d in rows["delta"].astype(float)
            ],
            "95% CI": interval,
            "verdict": rows["verdict"].fillna("-").astype(str),
            "drives": rows["n_drives"].astype("Int64").astype(str).replace("<NA>", "-"),
            "sequences": rows["n_sequences"].astype("Int64").astype(str).replace("<NA>", "-"),
            "model": rows["model"].astype(str),
        }
    )


def rules_lines() -> list[str]:
    """Return the drift rules as the page states them."""
    return [
        f"- **decline**: at least {DECLINE_STEPS} consecutive nights each worse than the one "
        "before, whose summed change reaches the KPI's drift margin.",
        "- **cusum**: one-sided CUSUM on the nightly changes in the worse direction, "
        f"S = max(0, S + change - {CUSUM_SLACK:g} x margin), alarm at S >= margin.",
        "- An alarm is *caught* when a night inside it had a comparison verdict `worse` for that "
        "KPI; the others are drifts no night's gate caught. Margins: `--margin KPI:VALUE`, else "
        "the KPI's own, else the defaults of docs/compare.md.",
    ]


def history_sections(
    series: pd.DataFrame,
    drifts: pd.DataFrame,
    model_changes: Sequence[tuple[str, str, str]],
    config_changes: Sequence[tuple[str, str, str]],
    plots: Mapping[str, str],
) -> list[Section]:
    """Return the page's sections; ``plots`` maps a KPI to its plot's path relative to the page."""
    nights = sorted(series["night"].unique())
    uncaught = drifts[~drifts["caught"].astype(bool)] if len(drifts) else drifts
    head = [
        f"{len(nights)} nights ({nights[0]} to {nights[-1]}), "
        f"{series['kpi'].nunique()} KPIs; {len(uncaught)} drift alarms no night's gate "
        f"caught, {len(drifts) - len(uncaught)} caught; {len(model_changes)} model changes, "
        f"{len(config_changes)} configuration changes.",
        *[f"- drift: {drift_line(r)}" for r in uncaught.to_dict("records")],
    ]
    sections = [Section("Drifts no gate caught", head)]
    if model_changes or config_changes:
        sections.append(
            Section(
                "Model and configuration changes",
                ["Marked in the plots: dashed red lines (model), dotted blue (configuration)."],
                [_changes_table(model_changes, config_changes)],
            )
        )
    if len(drifts):
        shown = drifts.assign(alarm=[drift_line(r) for r in drifts.to_dict("records")])
        sections.append(Section("Every drift alarm", rules_lines(), [shown[["rule", "alarm"]]]))
    for kpi in series["kpi"].drop_duplicates():
        spec = KPI_BY_NAME.get(str(kpi))
        title = f"{spec.label if spec else kpi} (`{kpi}`)"
        image = [plots[kpi]] if kpi in plots else []
        sections.append(Section(title, [], [_kpi_table(series, str(kpi))], image))
    sections.append(
        Section(
            "Querying the history",
            ["The dataset is plain hive-partitioned Parquet:", QUERY_EXAMPLE],
        )
    )
    return sections
