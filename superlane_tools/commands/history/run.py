"""``slt history ROOT -o OUT``: read the fleet's history, flag drifts, plot each KPI, write a page.

ROOT is a nightly root whose ``history/`` dataset ``pipelines/nightly.py`` appends to (or the
dataset folder itself). Writes ``history.md`` / ``history.html`` (drifts no gate caught first,
model and configuration changes, one plot and table per KPI), ``history_drifts.parquet`` and
``plots/history_<kpi>.png`` under OUT.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from superlane_tools.errors import UsageError
from superlane_tools.fleet import FleetError
from superlane_tools.fleet.drift import drifts as find_drifts
from superlane_tools.fleet.history import changes, history_dataset, nightly_series, read_history
from superlane_tools.fleet.history_report import drift_line, history_sections
from superlane_tools.reporting import Provenance, write_table
from superlane_tools.reporting.layout import HistoryReportLayout
from superlane_tools.reporting.report import write_report

if TYPE_CHECKING:
    import pandas as pd


@dataclass(frozen=True)
class HistoryParams:
    """Which KPIs, their drift margins (KPI unit), plots or not, and the command line."""

    kpis: tuple[str, ...] = ()
    margins: Mapping[str, float] = field(default_factory=dict)
    plots: bool = True
    command: str = ""


@dataclass(frozen=True)
class HistoryResult:
    """The nightly series, the drift alarms, the changes marked and the files written."""

    series: pd.DataFrame
    drifts: pd.DataFrame
    model_changes: tuple[tuple[str, str, str], ...]
    config_changes: tuple[tuple[str, str, str], ...]
    outputs: tuple[Path, ...]

    @property
    def uncaught(self) -> pd.DataFrame:
        """Return the drift alarms no night's gate caught."""
        return self.drifts[~self.drifts["caught"].astype(bool)]

    @property
    def drift_lines(self) -> list[str]:
        """Return one line per drift no night's gate caught."""
        return [drift_line(row) for row in self.uncaught.to_dict("records")]


def _dataset(root: Path, out: Path) -> Path:
    """Return ROOT's dataset; a usage error when ROOT is none or OUT would write into it."""
    try:
        dataset = history_dataset(root)
    except FleetError as err:
        raise UsageError(str(err)) from err
    if out.resolve().is_relative_to(dataset.resolve()):
        raise UsageError(f"--out {out} is inside the history dataset {dataset}")
    return dataset


def history_report(root: Path, out: Path, params: HistoryParams) -> HistoryResult:
    """Read ROOT's history, find drifts, write the page, the plots and the drift table.

    Raises:
        UsageError: If ROOT is not a history root, OUT lies inside its dataset, or a KPI asked
            for is not in the history.
        FleetError: If the dataset cannot be read.
    """
    dataset = _dataset(root, out)
    series = nightly_series(read_history(dataset))
    if params.kpis:
        unknown = sorted(set(params.kpis) - set(series["kpi"]))
        if unknown:
            raise UsageError(f"KPI not in the history: {', '.join(unknown)}")
        series = series[series["kpi"].isin(params.kpis)].reset_index(drop=True)
    alarms = find_drifts(series, params.margins)
    model_changes = tuple(changes(series, "model_id"))
    names = series.groupby("model_id")["model"].first().to_dict()
    model_changes = tuple(
        (night, f"{names.get(b, b)} ({b})", f"{names.get(a, a)} ({a})")
        for night, b, a in model_changes
    )
    config_changes = tuple(changes(series, "config_id"))
    layout = HistoryReportLayout(out)
    written: list[Path] = []
    plots: dict[str, str] = {}
    if params.plots:
        from superlane_tools.fleet.history_plot import plot_kpi_history

        for kpi in series["kpi"].drop_duplicates():
            path = plot_kpi_history(
                str(kpi),
                series,
                [(n, b, a.split(" (")[0]) for n, b, a in model_changes],
                config_changes,
                alarms,
                layout.kpi_plot(str(kpi)),
            )
            written.append(path)
            plots[str(kpi)] = path.relative_to(out).as_posix()
    provenance = Provenance(
        command=params.command or "slt history",
        config={"root": str(root), "margins": dict(params.margins), "kpis": list(params.kpis)},
    )
    written.append(write_table(alarms, layout.drifts, provenance))
    sections = history_sections(series, alarms, model_changes, config_changes, plots)
    written += write_report(layout.report, f"Fleet history: {root}", sections)
    return HistoryResult(series, alarms, model_changes, config_changes, tuple(written))
