"""SUPER multi-lane fit (paper section III): parallel lanes, heading, curvature and road slope.

The names below load their module on first use (PEP 562), so that the kernel compiler's
process (:mod:`superlane_tools.lanes.kernel_cache`) imports ``lanes._kernels`` without the fit's
other modules and their scipy.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from superlane_tools._lazy import lazy_attributes

if TYPE_CHECKING:
    from superlane_tools.lanes.attributes import CODE_OF, MARKING_CODES, Marking
    from superlane_tools.lanes.cost import CostFunction, Histogram, compensate, soft_histogram
    from superlane_tools.lanes.errors import FitParamsError, LaneFitError
    from superlane_tools.lanes.fit_lookahead import effective_lookahead
    from superlane_tools.lanes.multilane_fit import fit_frame
    from superlane_tools.lanes.params import FitParams
    from superlane_tools.lanes.peaks import assign, find_offsets
    from superlane_tools.lanes.project import columns_at_rows, lane_polyline, lanes_at_rows
    from superlane_tools.lanes.result import Lane, LaneFit

_HOMES = {
    "CODE_OF": "superlane_tools.lanes.attributes",
    "CostFunction": "superlane_tools.lanes.cost",
    "FitParams": "superlane_tools.lanes.params",
    "FitParamsError": "superlane_tools.lanes.errors",
    "Histogram": "superlane_tools.lanes.cost",
    "Lane": "superlane_tools.lanes.result",
    "LaneFit": "superlane_tools.lanes.result",
    "LaneFitError": "superlane_tools.lanes.errors",
    "MARKING_CODES": "superlane_tools.lanes.attributes",
    "Marking": "superlane_tools.lanes.attributes",
    "assign": "superlane_tools.lanes.peaks",
    "columns_at_rows": "superlane_tools.lanes.project",
    "compensate": "superlane_tools.lanes.cost",
    "effective_lookahead": "superlane_tools.lanes.fit_lookahead",
    "find_offsets": "superlane_tools.lanes.peaks",
    "fit_frame": "superlane_tools.lanes.multilane_fit",
    "lane_polyline": "superlane_tools.lanes.project",
    "lanes_at_rows": "superlane_tools.lanes.project",
    "soft_histogram": "superlane_tools.lanes.cost",
}


__getattr__ = lazy_attributes(__name__, globals(), _HOMES)


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
