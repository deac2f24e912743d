"""SUPER multi-lane fit of one frame (paper section III): lane and road pixels in, lines out.

Stages: flat-ground IPM of the pixels; a coarse loss-curve search (III-C) batched into one
vectorised cost evaluation, or the previous frame's solution; Nelder-Mead on J (Eq. 3) over
heading ``a1``, half curvature ``a2``, slope ``b`` (Eq. 10), optionally the road's vertical
curvature term ``c`` (``z = b x + c x^2``, beyond the paper) and, when J1 is used, the
road-centre offset ``a0c``; lane offsets as histogram peaks (Eq. 4); point-to-line
assignment; then, beyond the paper, a weighted least-squares refit of the shared model and a
bounded per-line correction. The pixels' rays are :mod:`._rays`; the lines built from the
shared model (assignment, corrections, ranges, markings) are :mod:`._lines`.
"""

from __future__ import annotations

import math
import time
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import minimize

from superlane_tools.camera.model import CameraModel
from superlane_tools.lanes._lines import (
    ASSIGN_ANGLE_RAD,
    assign_compiled,
    build_lanes,
    model_lookahead,
)
from superlane_tools.lanes._rays import RayPoints
from superlane_tools.lanes._refit import SharedModel, refit_shared
from superlane_tools.lanes.cost import CostFunction, CostSetup, kernels, ray_points
from superlane_tools.lanes.errors import LaneFitError
from superlane_tools.lanes.kernel_cache import warm_up
from superlane_tools.lanes.params import FitParams
from superlane_tools.lanes.peaks import assign, find_offsets, merge_close
from superlane_tools.lanes.result import Lane, LaneFit

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.intp]

REFIT_COST_SLACK = 0.05
"""Largest increase of J (nats) that a least-squares refit may cause and still be kept."""
SCAN_POINTS = 300
"""Lane points used by the batched loss-curve search."""
INIT_ROUNDS = 2
"""Coordinate-wise passes over the loss curves in the initial search."""
_STEP = np.array([0.01, 0.0005, 0.01, 0.5, 0.0001])
"""Nelder-Mead unit step of (a1 rad, a2 1/m, b, a0c m, c 1/m); tolerances are in these units."""


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
    road: RayPoints, camera: CameraModel, params: FitParams, t0: float, n_lane: int
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
    lane = RayPoints(camera, lane_uv, p)
    codes = _lane_codes(attributes, lane)
    use_road = p.lambda_road > 0 and (
        p.road_term == "always" or (p.road_term == "auto" and lane.size < p.road_term_below)
    )
    road = RayPoints(camera, road_uv if use_road else None, p)
    unfit = _without_optimiser(lane, road, camera, p, t0)
    if unfit is not None:
        return unfit
    height = camera.extrinsics.height_m
    setup = CostSetup(height, p, p.lambda_road if use_road else 0.0)
    sel = lane.sample(p.max_points, p.seed)
    solution = _optimise(setup, lane, sel, road, p, init)
    iqs, rs = lane.iq[sel], lane.r[sel]
    model, extras = _shared_model(iqs, rs, solution, height, p)
    lanes, quality = build_lanes(lane, model, codes, height, p)
    extras["lookahead_m"] = model_lookahead(iqs, rs, model, height, p)
    return _lane_fit(model, lanes, quality, solution, lane.size, extras, t0)


class _Solution(NamedTuple):
    """The optimiser's result: its cost function, theta ``(a1, a2, b, a0c, c)`` and J there."""

    cost: CostFunction
    theta: FloatArray
    iterations: int
    converged: bool
    j_final: float


def _without_optimiser(
    lane: RayPoints, road: RayPoints, camera: CameraModel, p: FitParams, t0: float
) -> LaneFit | None:
    """The fit of a frame with too few lane points (road alone, or none); None otherwise."""
    if lane.size == 0:
        if road.size >= p.min_points:
            return _road_only(road, camera, p, t0, 0)
        return LaneFit(reason="no lane pixels", fit_time_s=time.perf_counter() - t0)
    if lane.size < p.min_points:
        return LaneFit(
            reason="too few points", n_points=lane.size, fit_time_s=time.perf_counter() - t0
        )
    return None


def _optimise(
    setup: CostSetup,
    lane: RayPoints,
    sel: IntArray,
    road: RayPoints,
    p: FitParams,
    init: LaneFit | tuple[float, float, float] | None,
) -> _Solution:
    """Minimise J from ``init`` or from the loss-curve search when there is none."""
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
    return _Solution(cost, theta, nit, converged, cost(theta))


def _shared_model(
    iqs: FloatArray, rs: FloatArray, solution: _Solution, height: float, p: FitParams
) -> tuple[SharedModel, dict[str, float]]:
    """Lane offsets at the optimiser's solution, refitted when J agrees; the fit's extras."""
    a1, a2, b, a0c, cv = (float(v) for v in solution.theta)
    extras = {"nm_a1": a1, "nm_a2": a2, "nm_b": b}
    if p.vertical:
        extras["nm_c"] = cv
    x_s, y_s, _ok = ray_points(iqs, rs, b, height, p.max_range_m, cv)
    offsets = find_offsets(y_s - x_s * (a1 + a2 * x_s), p)
    model = SharedModel(a1, a2, b, offsets, cv)
    if p.refit and offsets.size:
        model = _refit(iqs, rs, model, height, p)
        if not _refit_kept(solution.cost, model, a0c, solution.j_final, p):
            model = SharedModel(a1, a2, b, offsets, cv)
        extras["refit_rejected"] = float(model.offsets is offsets)
    return model, extras


def _lane_fit(
    model: SharedModel,
    lanes: list[Lane],
    quality: float,
    solution: _Solution,
    n_points: int,
    extras: dict[str, float],
    t0: float,
) -> LaneFit:
    """The frame's fit: the model's lines, the ego pair around the camera and why it is short."""
    n_lines = len(lanes)
    reason = "" if n_lines >= 2 else ("one line" if n_lines == 1 else "no lines")
    left = [i for i, ln in enumerate(lanes) if ln.offset_m > 0]
    right = [i for i, ln in enumerate(lanes) if ln.offset_m <= 0]
    cost = solution.cost
    return LaneFit(
        a1=model.a1,
        a2=model.a2,
        b=model.b,
        c=model.c,
        lanes=tuple(lanes),
        ego_left=left[-1] if left else -1,
        ego_right=right[0] if right else -1,
        road_centre_m=float(solution.theta[3]) if cost.n_road else math.nan,
        cost=solution.j_final,
        iterations=solution.iterations,
        evaluations=cost.evaluations,
        converged=solution.converged,
        fit_time_s=time.perf_counter() - t0,
        quality=quality,
        reason=reason,
        n_points=n_points,
        extras=extras,
        shared_cov=model.cov if model.cov is not None else np.full((3, 3), math.nan),
    )


def _lane_codes(attributes: IntArray | None, lane: RayPoints) -> IntArray | None:
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
    lane: RayPoints,
    sel: IntArray,
    n_points: int,
    road: RayPoints,
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
            _x, _res, labels = assign_compiled(iqs, rs, model, height, p)
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
