"""Fleet comparison and mining: KPIs from run tables, intervals over drives, spans, frame picks."""

from superlane_tools.fleet.bootstrap import (
    BETTER,
    DESCRIPTIVE,
    EQUIVALENT,
    INCONCLUSIVE,
    LOST,
    MIN_DRIVES,
    SAME,
    TOO_FEW,
    UNAVAILABLE,
    UNPAIRED,
    VERDICTS,
    WORSE,
    BootstrapParams,
    Delta,
    drive_delta,
    holm,
    judge,
)
from superlane_tools.fleet.compare import Comparison, DriveKpis, compare_fleets
from superlane_tools.fleet.differences import difference_lines, run_differences
from superlane_tools.fleet.errors import FleetError
from superlane_tools.fleet.kpis import KPI_BY_NAME, KPIS, DriveTables, Kpi, sequence_kpis
from superlane_tools.fleet.load import LoadedFleets, drives_table, load
from superlane_tools.fleet.report import compare_sections, iso_time
from superlane_tools.fleet.runs import DriveRun, Fleet, find_drives, read_tables
from superlane_tools.fleet.spans import (
    SpanParams,
    disagreement_spans,
    frame_disagreement,
)
from superlane_tools.fleet.verdicts import (
    PRIMARY_KPIS,
    GateResult,
    GateRule,
    judge_gate,
    parse_rule,
    regressions,
    verdict_table,
)

__all__ = [
    "BETTER",
    "DESCRIPTIVE",
    "EQUIVALENT",
    "INCONCLUSIVE",
    "KPIS",
    "KPI_BY_NAME",
    "LOST",
    "MIN_DRIVES",
    "PRIMARY_KPIS",
    "SAME",
    "TOO_FEW",
    "UNAVAILABLE",
    "UNPAIRED",
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
    "GateResult",
    "GateRule",
    "Kpi",
    "LoadedFleets",
    "SpanParams",
    "compare_fleets",
    "compare_sections",
    "difference_lines",
    "disagreement_spans",
    "drive_delta",
    "drives_table",
    "find_drives",
    "frame_disagreement",
    "holm",
    "iso_time",
    "judge",
    "judge_gate",
    "load",
    "parse_rule",
    "read_tables",
    "regressions",
    "run_differences",
    "sequence_kpis",
    "verdict_table",
]
