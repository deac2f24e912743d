"""Lines from the shared model: point assignment, local corrections, ranges and markings.

The numpy reference (:func:`build_lanes`) and its compiled twin (``_build_lanes_compiled``) sit
side by side, as the cost's two backends do.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from superlane_tools.lanes._rays import RayPoints
from superlane_tools.lanes._refit import (
    NEAR_WEIGHT_M,
    LocalCorrection,
    SharedModel,
    local_correction,
    local_corrections_compiled,
)
from superlane_tools.lanes.attributes import (
    UNKNOWN,
    Marking,
    lane_attributes,
    marking_from_codes,
    style_from_coverage,
)
from superlane_tools.lanes.cost import kernels, ray_points
from superlane_tools.lanes.fit_lookahead import effective_lookahead, refit_sqrt_weights
from superlane_tools.lanes.params import FitParams
from superlane_tools.lanes.peaks import assign
from superlane_tools.lanes.result import Lane

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.intp]

ASSIGN_ANGLE_RAD = 0.008
"""Assignment radius growth with distance (radians): segmentation noise grows with range."""


def assign_compiled(
    iq: FloatArray, r: FloatArray, model: SharedModel, height: float, p: FitParams
) -> tuple[FloatArray, FloatArray, IntArray]:
    """Assign rays to the model's lines with the compiled kernel: ``x``, residual, labels."""
    out: tuple[FloatArray, FloatArray, IntArray] = kernels().assign_points(
        iq,
        r,
        model.a1,
        model.a2,
        model.b,
        model.c,
        1.0 / height,
        1.0 / p.max_range_m,
        np.ascontiguousarray(model.offsets, dtype=np.float64),
        p.assign_radius_m,
        ASSIGN_ANGLE_RAD,
    )
    return out


def model_lookahead(
    iqs: FloatArray, rs: FloatArray, model: SharedModel, height: float, p: FitParams
) -> float:
    """Effective look-ahead of the final model's ``2*a2`` over the points it was fitted to."""
    if model.offsets.size == 0:
        return math.nan
    x, y, ok = ray_points(iqs, rs, model.b, height, p.max_range_m, model.c)
    resid = np.where(ok, y - x * (model.a1 + model.a2 * x), np.nan)
    radius = p.assign_radius_m + ASSIGN_ANGLE_RAD * np.nan_to_num(x)
    labels = assign(resid, model.offsets, radius)
    x = np.where(ok, x, np.nan)
    return effective_lookahead(x, labels, refit_sqrt_weights(x, NEAR_WEIGHT_M))


def build_lanes(
    lane: RayPoints, model: SharedModel, codes: IntArray | None, height: float, p: FitParams
) -> tuple[list[Lane], float]:
    """Assign all usable points to the lines, add local corrections, ranges and attributes.

    The numpy reference (``backend="numpy"``) is the body below; ``numba`` runs its deliberate
    twin :func:`_build_lanes_compiled` (same formulas, single passes over the points). They are
    kept apart on purpose, like the cost's two backends, and tested against each other through
    :func:`~superlane_tools.lanes.multilane_fit.fit_frame` (``tests/lanes/test_lanes_kernels.py``,
    ``test_lanes_vertical.py``).
    """
    if model.offsets.size == 0:
        return [], 0.0
    if p.backend == "numba":
        return _build_lanes_compiled(lane, model, codes, height, p)
    x, y, ok = ray_points(lane.iq, lane.r, model.b, height, p.max_range_m, model.c)
    base = x * (model.a1 + model.a2 * x)
    resid = np.where(ok, y - base, np.nan)
    radius = p.assign_radius_m + ASSIGN_ANGLE_RAD * np.nan_to_num(x)
    labels = assign(resid, model.offsets, radius)
    corrections = []
    for n, offset in enumerate(model.offsets):
        mask = labels == n
        corr = (
            local_correction(x[mask], resid[mask] - offset, p.order, p.local_bound_m)
            if p.local_correction
            else None
        )
        corrections.append(corr)
    if p.local_correction:
        # Reassign with the corrected lines so that each line's range follows its own points.
        lane_res = np.stack(
            [
                resid - off - (c.c0 + x * (c.c1 + x * c.c2) if c else 0.0)
                for off, c in zip(model.offsets, corrections, strict=True)
            ],
            axis=1,
        )
        dist = np.where(np.isfinite(lane_res), np.abs(lane_res), np.inf)
        best = np.argmin(dist, axis=1)
        labels = np.where(dist[np.arange(best.size), best] <= radius, best, -1)
    marks = lane_attributes(labels, model.offsets.size, lane.rows, codes)
    lanes = []
    n_assigned = 0
    for n, offset in enumerate(model.offsets):
        mask = labels == n
        if not mask.any() or int(mask.sum()) < p.min_line_points:
            continue  # no evidence for a line here (the evidence rule, FitParams)
        n_assigned += int(mask.sum())
        c = corrections[n]
        xn = x[mask]
        lanes.append(
            Lane(
                offset_m=float(offset + (c.c0 if c else 0.0)),
                a1=model.a1 + (c.c1 if c else 0.0),
                a2=model.a2 + (c.c2 if c else 0.0),
                range_min_m=float(xn.min()),
                range_max_m=float(xn.max()),
                colour=marks[n].colour,
                style=marks[n].style,
                n_points=int(mask.sum()),
            )
        )
    lanes.sort(key=lambda ln: -ln.offset_m)
    return lanes, float(n_assigned) / max(lane.size, 1)


def _build_lanes_compiled(
    lane: RayPoints, model: SharedModel, codes: IntArray | None, height: float, p: FitParams
) -> tuple[list[Lane], float]:
    """:func:`build_lanes` with single-pass kernels over the points (same results).

    A deliberate twin of the numpy reference in :func:`build_lanes`, not a copy to merge: a
    change to one must be made to the other (the backend-comparison tests fail otherwise).
    """
    k = kernels()
    offsets = np.ascontiguousarray(model.offsets, dtype=np.float64)
    x, resid, labels = assign_compiled(lane.iq, lane.r, model, height, p)
    sums_x, sums_r = k.line_sums(x, resid, labels, offsets, NEAR_WEIGHT_M)
    if p.local_correction:
        coef = local_corrections_compiled(sums_x, sums_r, p.order, p.local_bound_m)
        lines = np.concatenate([offsets[:, None], coef], axis=1)
        labels = k.reassign(x, resid, lines, p.assign_radius_m, ASSIGN_ANGLE_RAD)
        _, sums_r = k.line_sums(x, resid, labels, offsets, NEAR_WEIGHT_M)
    else:
        coef = np.zeros((offsets.size, 3))
    corrections = [LocalCorrection(*(float(v) for v in row)) for row in coef]
    coverage = k.row_coverage(np.ascontiguousarray(lane.rows), labels, offsets.size)
    lanes = []
    n_assigned = 0
    for n, offset in enumerate(offsets):
        count = int(sums_r[n, 3])
        if count == 0 or count < p.min_line_points:
            continue  # no evidence for a line here (the evidence rule, FitParams)
        n_assigned += count
        mark = marking_from_codes(codes[labels == n]) if codes is not None else UNKNOWN
        if mark.style == "unknown":
            n_rows, first, last = (int(v) for v in coverage[n])
            mark = Marking(mark.colour, style_from_coverage(n_rows, last - first + 1))
        c = corrections[n]
        lanes.append(
            Lane(
                offset_m=float(offset + c.c0),
                a1=model.a1 + c.c1,
                a2=model.a2 + c.c2,
                range_min_m=float(sums_r[n, 4]),
                range_max_m=float(sums_r[n, 5]),
                colour=mark.colour,
                style=mark.style,
                n_points=count,
            )
        )
    lanes.sort(key=lambda ln: -ln.offset_m)
    return lanes, float(n_assigned) / max(lane.size, 1)
