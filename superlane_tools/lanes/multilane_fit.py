"""SUPER multi-lane fit of one frame (paper section III): lane and road pixels in, lines out.

Stages: flat-ground IPM of the pixels; a coarse loss-curve search (III-C) batched into one
vectorised cost evaluation, or the previous frame's solution; Nelder-Mead on J (Eq. 3) over
heading ``a1``, half curvature ``a2``, slope ``b`` (Eq. 10), optionally the road's vertical
curvature term ``c`` (``z = b x + c x^2``, beyond the paper) and, when J1 is used, the
road-centre offset ``a0c``; lane offsets as histogram peaks (Eq. 4); point-to-line
assignment; then, beyond the paper, a weighted least-squares refit of the shared model and a
bounded per-line correction.
"""

from __future__ import annotations

import math
import time

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import minimize

from superlane_tools.camera.model import CameraModel
from superlane_tools.lanes._refit import (
    NEAR_WEIGHT_M,
    LocalCorrection,
    SharedModel,
    local_correction,
    local_corrections_compiled,
    refit_shared,
)
from superlane_tools.lanes.attributes import (
    UNKNOWN,
    Marking,
    lane_attributes,
    marking_from_codes,
    style_from_coverage,
)
from superlane_tools.lanes.cost import CostFunction, CostSetup, kernels, ray_points
from superlane_tools.lanes.errors import LaneFitError
from superlane_tools.lanes.fit_lookahead import effective_lookahead, refit_sqrt_weights
from superlane_tools.lanes.kernel_cache import warm_up
from superlane_tools.lanes.params import FitParams
from superlane_tools.lanes.peaks import assign, find_offsets, merge_close
from superlane_tools.lanes.result import Lane, LaneFit

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.intp]

ASSIGN_ANGLE_RAD = 0.008
"""Assignment radius growth with distance (radians): segmentation noise grows with range."""
REFIT_COST_SLACK = 0.05
"""Largest increase of J (nats) that a least-squares refit may cause and still be kept."""
SCAN_POINTS = 300
INIT_ROUNDS = 2
"""Coordinate-wise passes over the loss curves in the initial search."""
"""Lane points used by the batched loss-curve search."""
_STEP = np.array([0.01, 0.0005, 0.01, 0.5, 0.0001])
"""Nelder-Mead unit step of (a1 rad, a2 1/m, b, a0c m, c 1/m); tolerances are in these units."""


class _Points:
    """Usable pixels as viewing rays ``(iq, r)`` from the camera foot (see ``cost``)."""

    def __init__(self, camera: CameraModel, uv: FloatArray | None, params: FitParams) -> None:
        pix = np.empty((0, 2)) if uv is None else np.asarray(uv, dtype=np.float64).reshape(-1, 2)
        if pix.size and not np.all(np.isfinite(pix)):
            raise LaneFitError("pixel coordinates must be finite")
        self.n_pixels = pix.shape[0]
        if self.n_pixels == 0:
            self.iq = self.r = self.rows = np.empty(0)
            self.index = np.empty(0, dtype=np.intp)
            return
        height = camera.extrinsics.height_m
        # Keep rays that meet the road within range for some admissible slope; a vertical
        # curvature term c acts as the extra slope c * x over the range.
        reach = (
            (params.slope_bound + params.vertical_curvature_bound * params.max_range_m) / height
            if params.slope
            else 0.0
        )
        if params.backend == "numba":
            xn, yn = camera.normalized(pix)
            iq, r, keep = kernels().ray_slopes(
                np.ascontiguousarray(xn),
                np.ascontiguousarray(yn),
                np.ascontiguousarray(camera.extrinsics.rotation, dtype=np.float64),
                height,
                reach,
                1.0 / params.max_range_m,
                1.0 / params.min_range_m,
            )
        else:
            dirs = camera.rays(pix)
            forward = dirs[:, 0] > 1e-9
            dx = np.where(forward, dirs[:, 0], 1.0)
            iq = -dirs[:, 2] / (height * dx)
            r = dirs[:, 1] / dx
            keep = (
                forward
                & (iq + reach >= 1.0 / params.max_range_m)
                & (iq - reach <= 1.0 / params.min_range_m)
            )
        self.index = np.flatnonzero(keep)
        self.iq, self.r, self.rows = iq[keep], r[keep], pix[keep, 1]

    @property
    def size(self) -> int:
        return int(self.iq.size)

    def sample(self, n_max: int, seed: int) -> IntArray:
        """Return sorted indices of a deterministic uniform subsample (image-pixel density)."""
        if self.size <= n_max:
            return np.arange(self.size)
        rng = np.random.default_rng(seed)
        return np.sort(rng.choice(self.size, n_max, replace=False))


def _initial_guess(cost: CostFunction, params: FitParams, free: list[int]) -> FloatArray:
    """Loss-curve search of III-C, batched: one vectorised evaluation per curve.

    The paper scans each parameter's loss curve with the others at zero. Far from zero (a strong
    slope with a curve) those curves mislead: curvature and slope, which both bend the lines
    apart in the BEV, first get a joint grid, then each loss curve is scanned coordinate-wise
    from the best point so far.
    """
    grids = {
        0: np.linspace(-params.heading_bound_rad, params.heading_bound_rad, params.grid_heading),
        1: np.linspace(-params.curvature_bound, params.curvature_bound, params.grid_curvature)
        / 2.0,
        2: np.linspace(-params.slope_bound, params.slope_bound, params.grid_slope),
        3: np.linspace(-params.offset_range_m / 2, params.offset_range_m / 2, 13),
        4: np.linspace(
            -params.vertical_curvature_bound, params.vertical_curvature_bound, params.grid_vertical
        ),
    }
    best = np.zeros(5)
    best_cost = np.inf
    if 1 in free and 2 in free:
        a2_grid, b_grid = np.meshgrid(grids[1], grids[2])
        thetas = np.zeros((a2_grid.size, 5))
        thetas[:, 1], thetas[:, 2] = a2_grid.ravel(), b_grid.ravel()
        costs = cost.batch(thetas)
        i = int(np.argmin(costs))
        best, best_cost = thetas[i].copy(), float(costs[i])
    for _ in range(INIT_ROUNDS):
        improved = False
        for k in free:
            thetas = np.repeat(best[None, :], grids[k].size, axis=0)
            thetas[:, k] = grids[k]
            costs = cost.batch(thetas)
            i = int(np.argmin(costs))
            if costs[i] < best_cost:
                improved = improved or not np.array_equal(thetas[i], best)
                best, best_cost = thetas[i].copy(), float(costs[i])
        if not improved:  # a pass that moved nothing: the next one would repeat it
            break
    return best


def _theta_from_init(init: LaneFit | tuple[float, float, float], params: FitParams) -> FloatArray:
    if isinstance(init, LaneFit):
        a1, a2, b, a0c, c = init.a1, init.a2, init.b, init.road_centre_m, init.c
    else:
        a1, a2, b = init
        a0c = c = 0.0
    theta = np.array([a1, a2 if params.order == 2 else 0.0, b if params.slope else 0.0, a0c, c])
    theta[~np.isfinite(theta)] = 0.0
    theta[2] = np.clip(theta[2], -params.slope_bound, params.slope_bound)
    cb = params.vertical_curvature_bound
    theta[4] = np.clip(theta[4], -cb, cb)
    return theta


def _nelder_mead(
    cost: CostFunction, theta0: FloatArray, free: list[int], params: FitParams
) -> tuple[FloatArray, int, bool]:
    """Minimise J over the free parameters, in units of ``_STEP``; return theta, nit, success."""
    base = theta0.copy()
    scale = _STEP[free]
    bounds_abs = {
        0: 2.0 * params.heading_bound_rad,
        1: params.curvature_bound / 2.0,
        2: params.slope_bound,
        3: params.offset_range_m,
        4: params.vertical_curvature_bound,
    }
    bounds = [(-bounds_abs[k] / _STEP[k], bounds_abs[k] / _STEP[k]) for k in free]
    x0 = np.clip(base[free] / scale, [lo for lo, _ in bounds], [hi for _, hi in bounds])

    def fun(v: FloatArray) -> float:
        theta = base.copy()
        theta[free] = v * scale
        return cost(theta)

    simplex = np.vstack([x0, x0 + np.eye(len(free))])
    for i, (lo, hi) in enumerate(bounds):
        col = simplex[:, i]
        col[col > hi] -= 2.0  # keep the initial simplex inside the bounds
        np.clip(col, lo, hi, out=col)
    if cost.backend == "numba":
        lo = np.array([b[0] for b in bounds])
        hi = np.array([b[1] for b in bounds])
        v, _fun, nit, nfev, ok = kernels().nelder_mead(
            simplex,
            base,
            np.asarray(free, dtype=np.intp),
            np.ascontiguousarray(scale),
            lo,
            hi,
            params.xatol,
            params.fatol,
            params.max_iterations,
            *cost.arrays,
            cost.cfg,
            cost.scratch,
        )
        cost.evaluations += int(nfev)
        theta = base.copy()
        theta[free] = np.asarray(v) * scale
        return theta, int(nit), bool(ok)
    res = minimize(
        fun,
        x0,
        method="Nelder-Mead",
        bounds=bounds,
        options={
            "xatol": params.xatol,
            "fatol": params.fatol,
            "maxiter": params.max_iterations,
            "initial_simplex": simplex,
        },
    )
    theta = base.copy()
    theta[free] = np.asarray(res.x) * scale
    return theta, int(res.nit), bool(res.success)


def _road_only(
    road: _Points, camera: CameraModel, params: FitParams, t0: float, n_lane: int
) -> LaneFit:
    """Fit the road centre line alone (J1) when there are no lane points."""
    idx = road.sample(params.max_road_points, params.seed)
    setup = CostSetup(camera.extrinsics.height_m, params, lambda_road=1.0)
    cost = setup.build(np.zeros(0), np.zeros(0), road.iq[idx], road.r[idx])
    free = [0, 1, 3] if params.order == 2 else [0, 3]
    theta0 = np.array([0.0, 0.0, 0.0, float(np.median(road.r[idx] / road.iq[idx]))])

    def road_cost(theta: FloatArray) -> float:
        cost.evaluations += 1
        return cost.road_term(float(theta[0]), float(theta[1]), 0.0, float(theta[3]))

    base = theta0.copy()

    def fun(v: FloatArray) -> float:
        theta = base.copy()
        theta[free] = v * _STEP[free]
        return road_cost(theta)

    res = minimize(
        fun,
        theta0[free] / _STEP[free],
        method="Nelder-Mead",
        options={"xatol": params.xatol, "fatol": params.fatol, "maxiter": params.max_iterations},
    )
    theta = base.copy()
    theta[free] = np.asarray(res.x) * _STEP[free]
    return LaneFit(
        a1=float(theta[0]),
        a2=float(theta[1]),
        b=0.0,
        road_centre_m=float(theta[3]),
        cost=float(res.fun),
        iterations=int(res.nit),
        evaluations=cost.evaluations,
        converged=bool(res.success),
        fit_time_s=time.perf_counter() - t0,
        reason="all road",
        n_points=n_lane,
    )


def fit_frame(
    lane_uv: FloatArray,
    road_uv: FloatArray | None,
    camera: CameraModel,
    params: FitParams | None = None,
    init: LaneFit | tuple[float, float, float] | None = None,
    attributes: IntArray | None = None,
) -> LaneFit:
    """Fit parallel lane lines, heading, curvature and road slope to one frame's pixels.

    Args:
        lane_uv: ``(N, 2)`` image pixels ``(u, v)`` of lane markings. All of them are used to
            assign lines and measure their view range; at most ``params.max_points`` of them,
            sampled uniformly (deterministic seed), drive the optimiser.
        road_uv: ``(M, 2)`` road pixels for J1, or None.
        camera: Camera that took the frame (its image size must match the pixels).
        params: Fit parameters (paper defaults when None).
        init: Previous frame's fit (or ``(a1, a2, b)``) as the initial guess; None runs the
            loss-curve search of III-C.
        attributes: ``(N,)`` level-4 marking codes of the lane pixels
            (:data:`superlane_tools.lanes.attributes.MARKING_CODES` order), or None.

    Returns:
        The frame's fit; ``reason`` says why a frame has no (or only one) line.

    Raises:
        LaneFitError: If the inputs are inconsistent (shapes, non-finite pixels).
    """
    p = params or FitParams()
    warm_up(p.backend)  # kernel loading is set-up, not per-frame fit time
    t0 = time.perf_counter()
    lane = _Points(camera, lane_uv, p)
    codes = _lane_codes(attributes, lane)
    use_road = p.lambda_road > 0 and (
        p.road_term == "always" or (p.road_term == "auto" and lane.size < p.road_term_below)
    )
    road = _Points(camera, road_uv if use_road else None, p)
    if lane.size == 0:
        if road.size >= p.min_points:
            return _road_only(road, camera, p, t0, 0)
        return LaneFit(reason="no lane pixels", fit_time_s=time.perf_counter() - t0)
    if lane.size < p.min_points:
        return LaneFit(
            reason="too few points", n_points=lane.size, fit_time_s=time.perf_counter() - t0
        )

    height = camera.extrinsics.height_m
    setup = CostSetup(height, p, p.lambda_road if use_road else 0.0)
    sel = lane.sample(p.max_points, p.seed)
    ridx = road.sample(p.max_road_points, p.seed) if road.size else None
    cost = _cost_over(setup, lane, sel, p.nm_points, road, ridx)
    free = _free_parameters(p, cost.n_road > 0)
    if init is not None:
        theta0 = _theta_from_init(init, p)
    else:
        scan = _cost_over(setup, lane, sel, SCAN_POINTS, road, None if ridx is None else ridx[::4])
        theta0 = _initial_guess(scan, p, free)
        cost.evaluations += scan.evaluations
    theta, nit, converged = _nelder_mead(cost, theta0, free, p)
    j_final = cost(theta)
    a1, a2, b, a0c, cv = (float(v) for v in theta)
    extras = {"nm_a1": a1, "nm_a2": a2, "nm_b": b}
    if p.vertical:
        extras["nm_c"] = cv

    iqs, rs = lane.iq[sel], lane.r[sel]
    x_s, y_s, _ok = ray_points(iqs, rs, b, height, p.max_range_m, cv)
    offsets = find_offsets(y_s - x_s * (a1 + a2 * x_s), p)
    model = SharedModel(a1, a2, b, offsets, cv)
    if p.refit and offsets.size:
        model = _refit(iqs, rs, model, height, p)
        if not _refit_kept(cost, model, a0c, j_final, p):
            model = SharedModel(a1, a2, b, offsets, cv)
        extras["refit_rejected"] = float(model.offsets is offsets)

    lanes, quality = _build_lanes(lane, model, codes, height, p)
    extras["lookahead_m"] = _lookahead(iqs, rs, model, height, p)
    n_lines = len(lanes)
    reason = "" if n_lines >= 2 else ("one line" if n_lines == 1 else "no lines")
    left = [i for i, ln in enumerate(lanes) if ln.offset_m > 0]
    right = [i for i, ln in enumerate(lanes) if ln.offset_m <= 0]
    return LaneFit(
        a1=model.a1,
        a2=model.a2,
        b=model.b,
        c=model.c,
        lanes=tuple(lanes),
        ego_left=left[-1] if left else -1,
        ego_right=right[0] if right else -1,
        road_centre_m=a0c if cost.n_road else math.nan,
        cost=j_final,
        iterations=nit,
        evaluations=cost.evaluations,
        converged=converged,
        fit_time_s=time.perf_counter() - t0,
        quality=quality,
        reason=reason,
        n_points=lane.size,
        extras=extras,
        shared_cov=model.cov if model.cov is not None else np.full((3, 3), math.nan),
    )


def _lane_codes(attributes: IntArray | None, lane: _Points) -> IntArray | None:
    """The marking codes of the usable lane pixels (None without attributes)."""
    if attributes is None:
        return None
    codes_all = np.asarray(attributes, dtype=np.intp).reshape(-1)
    if codes_all.size != lane.n_pixels:
        raise LaneFitError(
            f"attributes has {codes_all.size} entries for {lane.n_pixels} lane pixels"
        )
    return codes_all[lane.index]


def _cost_over(
    setup: CostSetup,
    lane: _Points,
    sel: IntArray,
    n_points: int,
    road: _Points,
    ridx: IntArray | None,
) -> CostFunction:
    """J over about ``n_points`` of the sampled lane points ``sel`` (every k-th) and ``ridx``."""
    sub = sel[:: max(1, -(-sel.size // n_points))]
    return setup.build(
        lane.iq[sub],
        lane.r[sub],
        road.iq[ridx] if ridx is not None else None,
        road.r[ridx] if ridx is not None else None,
    )


def _free_parameters(p: FitParams, with_road: bool) -> list[int]:
    """Indices of theta ``(a1, a2, b, a0c, c)`` that the optimiser moves."""
    free = [0]
    if p.order == 2:
        free.append(1)
    if p.slope:
        free.append(2)
    if with_road:
        free.append(3)
    if p.vertical:
        free.append(4)
    return free


def _refit(
    iqs: FloatArray, rs: FloatArray, model: SharedModel, height: float, p: FitParams
) -> SharedModel:
    """Two rounds of point assignment and weighted least-squares refit of the shared model."""
    for _ in range(2):
        if p.backend == "numba":
            _x, _res, labels = _assign_compiled(iqs, rs, model, height, p)
        else:
            x_c, y_c, _ok = ray_points(iqs, rs, model.b, height, p.max_range_m, model.c)
            resid = y_c - x_c * (model.a1 + model.a2 * x_c)
            radius = p.assign_radius_m + ASSIGN_ANGLE_RAD * np.nan_to_num(x_c)
            labels = assign(resid, model.offsets, radius)
        model = refit_shared(
            iqs,
            rs,
            labels,
            model.offsets.size,
            model,
            height,
            p.order,
            p.slope,
            p.slope_bound,
            p.max_range_m,
            compiled=p.backend == "numba",
            vertical_bound=p.vertical_curvature_bound,
        )
        merged = merge_close(np.sort(model.offsets), 0.5 * p.min_peak_separation_m)
        model = model._replace(offsets=merged)
    return model


def _assign_compiled(
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


def _refit_kept(
    cost: CostFunction, model: SharedModel, a0c: float, j_final: float, p: FitParams
) -> bool:
    """Whether J agrees that the refit ``model`` is no worse than the optimiser's solution.

    A wrong assignment can make least squares run away. A single line (often short: a stripe,
    a curb) constrains nothing across lines, so its refit must also stay inside the
    optimiser's bounds.
    """
    j_refit = cost(np.array([model.a1, model.a2, model.b, a0c, model.c]))
    inside = model.offsets.size >= 2 or (
        abs(model.a1) <= 2.0 * p.heading_bound_rad and abs(model.a2) <= p.curvature_bound / 2
    )
    return bool(inside and np.isfinite(j_refit) and j_refit <= j_final + REFIT_COST_SLACK)


def _lookahead(
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


def _build_lanes(
    lane: _Points, model: SharedModel, codes: IntArray | None, height: float, p: FitParams
) -> tuple[list[Lane], float]:
    """Assign all usable points to the lines, add local corrections, ranges and attributes.

    The numpy reference (``backend="numpy"``) is the body below; ``numba`` runs its deliberate
    twin :func:`_build_lanes_compiled` (same formulas, single passes over the points). They are
    kept apart on purpose, like the cost's two backends, and tested against each other through
    :func:`fit_frame` (``tests/lanes/test_lanes_kernels.py``, ``test_lanes_vertical.py``).
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
    lane: _Points, model: SharedModel, codes: IntArray | None, height: float, p: FitParams
) -> tuple[list[Lane], float]:
    """:func:`_build_lanes` with single-pass kernels over the points (same results).

    A deliberate twin of the numpy reference in :func:`_build_lanes`, not a copy to merge: a
    change to one must be made to the other (the backend-comparison tests fail otherwise).
    """
    k = kernels()
    offsets = np.ascontiguousarray(model.offsets, dtype=np.float64)
    x, resid, labels = _assign_compiled(lane.iq, lane.r, model, height, p)
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
