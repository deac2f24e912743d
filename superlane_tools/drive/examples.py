"""Example frames kept for the SUPER Fig. 8 style plot (a handful, never all frames)."""

from __future__ import annotations

from typing import Any

import numpy as np

from superlane_tools.commands.reprocess.stages import Finished
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
