"""Plot one KPI over the nights: its value, the verdicts, model and config changes, drifts."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from superlane_tools.fleet.kpis import KPI_BY_NAME
from superlane_tools.reporting.plots import _pyplot, _save

if TYPE_CHECKING:
    import pandas as pd

VERDICT_COLOURS = {"better": "tab:green", "worse": "tab:red"}


def plot_kpi_history(
    kpi: str,
    series: pd.DataFrame,
    model_changes: Sequence[tuple[str, str, str]],
    config_changes: Sequence[tuple[str, str, str]],
    drifts: pd.DataFrame,
    path: Path,
) -> Path:
    """Plot a KPI's nightly fleet value and write it as a PNG at ``path``.

    Points are coloured by that night's comparison verdict (red worse, green better, grey
    otherwise or none); a dashed red line marks a model change, a dotted blue one a
    configuration change; a shaded band marks each drift alarm (orange: no night's gate
    caught it, grey: caught).
    """
    plt = _pyplot()
    rows = series[series["kpi"] == kpi].sort_values("night")
    nights = rows["night"].tolist()
    x = np.arange(len(nights))
    pos = {n: k for k, n in enumerate(nights)}
    values = rows["value"].to_numpy(np.float64)
    spec = KPI_BY_NAME.get(kpi)
    scale = 100.0 if spec is not None and spec.unit == "ratio" else 1.0
    fig, ax = plt.subplots(figsize=(9, 3.2))
    ax.plot(x, values * scale, color="0.3", linewidth=1.2, zorder=2, label="fleet value")
    colours = [VERDICT_COLOURS.get(str(v), "0.6") for v in rows["verdict"]]
    ax.scatter(x, values * scale, c=colours, s=30, zorder=3)
    for night, _, after in model_changes:
        if night in pos:
            ax.axvline(
                pos[night] - 0.5, color="tab:red", linestyle="--", linewidth=1, label="model change"
            )
            ax.annotate(
                f"model: {after}",
                (pos[night] - 0.5, 1.0),
                xycoords=("data", "axes fraction"),
                fontsize=7,
                rotation=90,
                va="top",
                ha="right",
            )
    for night, _, _ in config_changes:
        if night in pos:
            ax.axvline(
                pos[night] - 0.45,
                color="tab:blue",
                linestyle=":",
                linewidth=1,
                label="config change",
            )
    for drift in drifts[drifts["kpi"] == kpi].itertuples():
        lo, hi = pos.get(str(drift.first_night)), pos.get(str(drift.last_night))
        if lo is not None and hi is not None:
            colour = "0.85" if drift.caught else "tab:orange"
            what = "drift (a gate caught it)" if drift.caught else "drift no gate caught"
            ax.axvspan(lo, hi, color=colour, alpha=0.25, zorder=1, label=what)
    ax.set_xticks(x, nights, rotation=30, ha="right", fontsize=7)
    unit = "%" if scale == 100.0 else (spec.unit if spec is not None else "")
    label = spec.label if spec is not None else kpi
    ax.set_title(f"{label} ({unit}) over the nights", fontsize=9)
    ax.grid(True, axis="y", alpha=0.3)
    handles, labels = ax.get_legend_handles_labels()
    unique = dict(zip(labels, handles, strict=True))
    ax.legend(unique.values(), unique.keys(), fontsize=7, loc="best")
    fig.tight_layout()
    return _save(fig, path)
