"""SUPER multi-lane fit (paper section III): parallel lanes, heading, curvature and road slope."""

from superlane_tools.lanes.attributes import CODE_OF, MARKING_CODES, Marking
from superlane_tools.lanes.cost import CostFunction, Histogram, compensate, soft_histogram
from superlane_tools.lanes.errors import FitParamsError, LaneFitError
from superlane_tools.lanes.fit_lookahead import effective_lookahead
from superlane_tools.lanes.multilane_fit import fit_frame
from superlane_tools.lanes.params import FitParams
from superlane_tools.lanes.peaks import assign, find_offsets
from superlane_tools.lanes.project import columns_at_rows, lane_polyline, lanes_at_rows
from superlane_tools.lanes.result import Lane, LaneFit

__all__ = [
    "CODE_OF",
    "MARKING_CODES",
    "CostFunction",
    "FitParams",
    "FitParamsError",
    "Histogram",
    "Lane",
    "LaneFit",
    "LaneFitError",
    "Marking",
    "assign",
    "columns_at_rows",
    "compensate",
    "effective_lookahead",
    "find_offsets",
    "fit_frame",
    "lane_polyline",
    "lanes_at_rows",
    "soft_histogram",
]
