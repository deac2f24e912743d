"""The lanes table: one row per frame's SUPER fit, list columns with one entry per lane.

The columns (:data:`FIT_COLUMNS`) are the lane fit's part of the tables that
``slt lanes fit`` and ``slt reprocess`` write; their whole schemas (and file names) are in
:mod:`superlane_tools.reporting.layout`.
"""

from __future__ import annotations

import math
from typing import Any

import pyarrow as pa

from superlane_tools.lanes.result import Lane, LaneFit

FIT_COLUMNS = pa.schema(
    [
        ("name", pa.string()),
        ("width", pa.int32()),
        ("height", pa.int32()),
        ("a1", pa.float64()),
        ("a2", pa.float64()),
        ("curvature", pa.float64()),
        ("b", pa.float64()),
        ("offsets", pa.list_(pa.float64())),
        ("lane_a1", pa.list_(pa.float64())),
        ("lane_a2", pa.list_(pa.float64())),
        ("colours", pa.list_(pa.string())),
        ("styles", pa.list_(pa.string())),
        ("range_min", pa.list_(pa.float64())),
        ("range_max", pa.list_(pa.float64())),
        ("n_lane_points", pa.list_(pa.int64())),
        ("ego_left", pa.int32()),
        ("ego_right", pa.int32()),
        ("lane_width", pa.float64()),
        ("cost", pa.float64()),
        ("iterations", pa.int32()),
        ("converged", pa.bool_()),
        ("fit_time_ms", pa.float64()),
        ("quality", pa.float64()),
        ("reason", pa.string()),
        ("c", pa.float64()),
    ]
)
"""The lane fit's columns, one row per frame; list columns hold one entry per lane; ``c`` is the
road's vertical curvature term (1/m, ``z = b x + c x^2``)."""


def fit_row(name: str, width: int, height: int, fit: LaneFit) -> dict[str, Any]:
    """Return the lane fit's columns of one frame (see :data:`FIT_COLUMNS`)."""
    lanes = fit.lanes
    return {
        "name": name,
        "width": width,
        "height": height,
        "a1": fit.a1,
        "a2": fit.a2,
        "curvature": fit.curvature,
        "b": fit.b,
        "offsets": [ln.offset_m for ln in lanes],
        "lane_a1": [ln.a1 for ln in lanes],
        "lane_a2": [ln.a2 for ln in lanes],
        "colours": [ln.colour for ln in lanes],
        "styles": [ln.style for ln in lanes],
        "range_min": [ln.range_min_m for ln in lanes],
        "range_max": [ln.range_max_m for ln in lanes],
        "n_lane_points": [ln.n_points for ln in lanes],
        "ego_left": fit.ego_left,
        "ego_right": fit.ego_right,
        "lane_width": fit.lane_width_m,
        "cost": fit.cost,
        "iterations": fit.iterations,
        "converged": fit.converged,
        "fit_time_ms": fit.fit_time_s * 1e3,
        "quality": fit.quality,
        "reason": fit.reason,
        "c": fit.c,
    }


def lanes_from_row(row: dict[str, Any]) -> tuple[list[Lane], float]:
    """Rebuild a frame's lanes and slope ``b`` from its ``lanes.parquet`` row."""
    lanes = [
        Lane(
            offset_m=float(o),
            a1=float(a1),
            a2=float(a2),
            range_min_m=float(lo),
            range_max_m=float(hi),
        )
        for o, a1, a2, lo, hi in zip(
            row["offsets"],
            row["lane_a1"],
            row["lane_a2"],
            row["range_min"],
            row["range_max"],
            strict=True,
        )
    ]
    b = row["b"]
    return lanes, float(b) if b is not None and math.isfinite(b) else 0.0
