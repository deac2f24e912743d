"""Plots of ``slt compare``: the fleet's and each drive's KPI deltas, availability timelines."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd

from superlane_tools.reporting.names import AVAILABILITY_NAMES
from superlane_tools.reporting.plots import _pyplot, _save

MAX_DRIVES_SHOWN = 30
"""Drives per delta plot (those with the largest deltas)."""


def plot_deltas(table: pd.DataFrame, kpis: Sequence[str], path: Path) -> Path:
    """Plot per-drive deltas (candidate - base) beside the fleet's, one panel per KPI.

    ``table`` is the comparison table (scopes ``drive`` and ``fleet``); the fleet's delta, with
    its interval over drives, is the first bar of each panel; a drive's delta is descriptive
    (no interval: one drive's sequences are not independent).
    """
    plt = _pyplot()
    fig, axes = plt.subplots(len(kpis), 1, figsize=(9, 2.2 * len(kpis) + 0.6), squeeze=False)
    for ax, kpi in zip(axes[:, 0], kpis, strict=True):
        rows = table[(table["kpi"] == kpi) & table["scope"].isin(["fleet", "drive"])]
        fleet = rows[rows["scope"] == "fleet"]
        drives = rows[rows["scope"] == "drive"]
        drives = drives.reindex(drives["delta"].abs().sort_values(ascending=False).index)
        shown = pd.concat([fleet, drives.head(MAX_DRIVES_SHOWN)])
        x = np.arange(len(shown))
        delta = shown["delta"].to_numpy(np.float64)
        lo = delta - shown["ci_low"].to_numpy(np.float64)
        hi = shown["ci_high"].to_numpy(np.float64) - delta
        colours = [_colour(v) for v in shown["verdict"]]
        ax.bar(x, np.nan_to_num(delta), color=colours)
        ax.errorbar(x, delta, yerr=np.vstack([lo, hi]), fmt="none", ecolor="k", capsize=3)
        ax.axhline(0.0, color="0.5", linewidth=0.8)
        labels = [
            "fleet" if s == "fleet" else str(d)
            for s, d in zip(shown["scope"], shown["drive"], strict=True)
        ]
        ax.set_xticks(x, labels, rotation=30, ha="right", fontsize=7)
        unit = str(shown["unit"].iloc[0]) if len(shown) else ""
        label = str(shown["label"].iloc[0]) if len(shown) else kpi
        ax.set_title(f"{label}: candidate - base ({unit})", fontsize=9)
    fig.tight_layout()
    return _save(fig, path)


def _colour(verdict: object) -> str:
    return {"better": "tab:green", "worse": "tab:red"}.get(str(verdict), "tab:gray")


def plot_timelines(
    drive: str,
    base: pd.DataFrame,
    candidate: pd.DataFrame,
    spans: pd.DataFrame,
    path: Path,
) -> Path:
    """Plot both runs' per-frame availability side by side for one drive, spans shaded.

    ``base`` / ``candidate``: the runs' ``availability_frames`` tables; ``spans``: the drive's
    disagreement spans (``start_ns``, ``stop_ns``).
    """
    plt = _pyplot()
    methods = [m for m in AVAILABILITY_NAMES if m in set(base["method"]) | set(candidate["method"])]
    fig, ax = plt.subplots(figsize=(9, 0.5 * 2 * len(methods) + 1.2))
    t0 = int(min(base["log_time_ns"].min(), candidate["log_time_ns"].min()))
    ticks, names = [], []
    y = 0
    for method in methods:
        for run, frame, colour in (("base", base, "tab:blue"), ("cand.", candidate, "tab:orange")):
            sel = frame[frame["method"] == method]
            t = (sel["log_time_ns"].to_numpy(np.int64) - t0) / 1e9
            ok = sel["available"].to_numpy(bool)
            ax.scatter(t[ok], np.full(ok.sum(), y), s=6, marker="|", color=colour)
            ax.scatter(t[~ok], np.full((~ok).sum(), y), s=6, marker="|", color="0.85")
            ticks.append(y)
            names.append(f"{AVAILABILITY_NAMES[method]} {run}")
            y += 1
    starts = (spans["start_ns"].to_numpy(np.int64) - t0) / 1e9
    stops = (spans["stop_ns"].to_numpy(np.int64) - t0) / 1e9
    for a, b in zip(starts, stops, strict=True):
        ax.axvspan(a, b, color="tab:red", alpha=0.15)
    ax.set_yticks(ticks, names, fontsize=7)
    ax.set_xlabel("time since the first frame (s); shaded: disagreement spans")
    ax.set_title(f"{drive}: available frames (coloured) per method and run", fontsize=9)
    fig.tight_layout()
    return _save(fig, path)
