"""Fleet comparison and mining: KPIs from run tables, bootstrap verdicts, spans, frame picks."""

from superlane_tools.fleet.bootstrap import (
    BETTER,
    SAME,
    TOO_FEW,
    UNAVAILABLE,
    VERDICTS,
    WORSE,
    BootstrapParams,
    Delta,
    kpi_delta,
    verdict,
)
from superlane_tools.fleet.compare import Comparison, DriveKpis, compare_fleets
from superlane_tools.fleet.differences import run_differences
from superlane_tools.fleet.errors import FleetError
from superlane_tools.fleet.kpis import KPI_BY_NAME, KPIS, DriveTables, Kpi, sequence_kpis
from superlane_tools.fleet.report import compare_sections, iso_time
from superlane_tools.fleet.runs import DriveRun, Fleet, find_drives, read_tables
from superlane_tools.fleet.spans import (
    SpanParams,
    disagreement_spans,
    frame_disagreement,
)
from superlane_tools.fleet.verdicts import GateRule, parse_rule, regressions, verdict_table

__all__ = [
    "BETTER",
    "KPIS",
    "KPI_BY_NAME",
    "SAME",
    "TOO_FEW",
    "UNAVAILABLE",
    "VERDICTS",
    "WORSE",
    "BootstrapParams",
    "Comparison",
    "Delta",
    "DriveKpis",
    "DriveRun",
    "DriveTables",
    "Fleet",
    "FleetError",
    "GateRule",
    "Kpi",
    "SpanParams",
    "compare_fleets",
    "compare_sections",
    "disagreement_spans",
    "find_drives",
    "frame_disagreement",
    "iso_time",
    "kpi_delta",
    "parse_rule",
    "read_tables",
    "regressions",
    "run_differences",
    "sequence_kpis",
    "verdict",
    "verdict_table",
]
