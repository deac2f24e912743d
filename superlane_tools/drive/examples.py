"""What a finished frame shows: lane drawings, the published lane parameters, example frames.

Example frames feed the SUPER Fig. 8 style plot (a handful, never all frames).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from superlane_tools.drive.stages import Finished
from superlane_tools.lanes import lane_polyline
from superlane_tools.reporting.plots import ExampleFrame, LineDrawing

MAX_BEV_POINTS = 4000


def lane_drawings(done: Finished) -> list[LineDrawing]:
    """Return the fitted lanes as image polylines with colour and style (processing size)."""
    fit = done.fit
    out = []
    slope = fit.b if np.isfinite(fit.b) else 0.0
    for k, lane in enumerate(fit.lanes):
        uv = lane_polyline(lane, slope, done.camera, 64, fit.c if np.isfinite(fit.c) else 0.0)
        ego = k in (fit.ego_left, fit.ego_right)
        out.append(LineDrawing(uv, lane.colour, lane.style, ego))
    return out


def lane_parameters(done: Finished) -> dict[str, Any]:
    """Return the per-frame lane parameters published next to the annotations (JSON-able)."""
    fit = done.fit

    def num(v: float) -> float | None:
        return float(v) if math.isfinite(v) else None

    return {
        "frame_index": done.prepared.index,
        "a1_rad": num(fit.a1),
        "a2_per_m": num(fit.a2),
        "curvature_per_m": num(fit.curvature) if fit.ok else None,
        "slope": num(fit.b),
        "ego_left": fit.ego_left,
        "ego_right": fit.ego_right,
        "lane_width_m": num(fit.lane_width_m),
        "quality": float(fit.quality),
        "reason": fit.reason,
        "lanes": [
            {
                "offset_m": ln.offset_m,
                "a1_rad": ln.a1,
                "a2_per_m": ln.a2,
                "range_min_m": ln.range_min_m,
                "range_max_m": ln.range_max_m,
                "colour": ln.colour,
                "style": ln.style,
            }
            for ln in fit.lanes
        ],
        "super_corridor_width_m": num(done.super_corridor.width_m),
        "corridor_net_width_m": num(done.net_corridor.width_m),
        "corridor_net_length_m": num(done.net_corridor.length_m),
    }


def example_indices(total: int | None, count: int) -> set[int]:
    """Return the indices of ``count`` example frames spread over ``total`` (None: unknown)."""
    if count <= 0:
        return set()
    if not total:
        return {10 * (k + 1) for k in range(count)}
    return {int(total * (k + 1) / (count + 1)) for k in range(count)}


def example_frame(done: Finished) -> ExampleFrame:
    """Collect what the example plot needs from one finished frame."""
    prep, fit = done.prepared, done.fit
    assert prep.image is not None
    assert prep.labels is not None
    uv = prep.lane_uv
    if uv.shape[0] > MAX_BEV_POINTS:
        uv = uv[np.random.default_rng(0).choice(uv.shape[0], MAX_BEV_POINTS, replace=False)]
    xy, valid = done.camera.ground_points(uv) if uv.size else (np.empty((0, 2)), np.empty(0, bool))
    xy = xy[valid & (xy[:, 0] < 80.0)] if uv.size else xy
    if fit.ok:
        residual = xy[:, 1] - (fit.a1 * xy[:, 0] + fit.a2 * xy[:, 0] ** 2)
    else:
        residual = xy[:, 1].copy()
    extra: dict[str, Any] = {
        "curvature": fit.curvature,
        "lanes": len(fit.lanes),
        "reason": fit.reason,
    }
    return ExampleFrame(
        frame_index=prep.index,
        t_ns=prep.log_time_ns,
        image_bgr=prep.image,
        labels=prep.labels,
        bev_xy=xy,
        residual_m=residual,
        offsets_m=np.asarray(fit.offsets, dtype=np.float64),
        lanes=lane_drawings(done),
        info=extra,
    )
