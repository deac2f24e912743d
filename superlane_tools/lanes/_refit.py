"""Least-squares refinement after point-to-line assignment (a step beyond the paper).

Once every lane point belongs to a line, the shared model ``y = o_n + a1 x + a2 x^2`` on the
road ``z = b x + c x^2`` is fitted by weighted Gauss-Newton: linear in ``(o_n, a1, a2)``, with
the slope ``b`` (and, when enabled, the vertical curvature term ``c``) linearised through the ray
form of Eq. 10, ``x = 1 / (iq + b / h)``, ``y = r x`` (``dx/db = -x^2 / h``, ``dy/db = -x y / h``;
on the curved road ``c x^2 / h + (iq + b / h) x = 1`` gives ``dx/db = -x / (h s)`` and
``dx/dc = x dx/db`` with ``s = sqrt((iq + b / h)^2 + 4 c / h)``). Residuals are weighted by
``1 / x`` so that the fit minimises image-space (pixel) error, not metres at 100 m.

The refit also returns the covariance of the shared ``(a1, a2, b)``: ``sigma^2 (J^T W J)^-1``
with ``sigma^2`` the weighted sum of squared residuals over ``n - p`` (``p``: all fitted
parameters), the block of the full inverse, so the per-line offsets (and ``c``) are nuisance
parameters (the Schur complement). It assumes independent pixels; they are not (a marking's
error is shared by its pixels), so a consumer should inflate it (see the lane tracker).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from superlane_tools.lanes.cost import road_den

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.intp]

NEAR_WEIGHT_M = 5.0
"""Forward distance below which the ``1 / x`` weight stops growing, metres."""


class SharedModel(NamedTuple):
    """Shared lane parameters and per-line offsets (metres, radians, 1/m, rise over run).

    ``c`` is the road's vertical curvature term (1/m) of ``z = b x + c x^2``; 0 on the linear
    road of the paper.
    """

    a1: float
    a2: float
    b: float
    offsets: FloatArray
    c: float = 0.0
    cov: FloatArray | None = None


N_SHARED = 3
"""Rows of the shared covariance: ``a1`` (radians), ``a2`` (1/m), ``b`` (rise over run)."""


def shared_covariance(
    normal: FloatArray,
    ssr_w: float,
    n_used: int,
    n_lines: int,
    order: int,
    fit_slope: bool,
) -> FloatArray:
    """Return the 3x3 covariance of ``(a1, a2, b)`` of a weighted least-squares fit.

    Args:
        normal: ``J^T W J`` with columns ``offsets..., a1, [a2], [b], [c]``.
        ssr_w: Weighted sum of squared residuals at the solution.
        n_used: Points in the fit.
        n_lines: Number of offset columns.
        order: Polynomial order (1: no ``a2`` column).
        fit_slope: Whether ``b`` has a column.

    Returns:
        The covariance; rows and columns of parameters not fitted (or all, when the fit has
        no redundancy or a singular normal matrix) are NaN.
    """
    out = np.full((N_SHARED, N_SHARED), np.nan)
    m = normal.shape[0]
    if n_used <= m or not math.isfinite(float(normal.sum())):
        return out
    ridged = normal.copy()
    ridged.flat[:: m + 1] += 1e-9 * (float(np.trace(normal)) / m + 1.0)
    try:
        inv = np.linalg.inv(ridged)
    except np.linalg.LinAlgError:
        return out
    rows = [0, *([1] if order == 2 else []), *([2] if fit_slope else [])]
    k = len(rows)
    block = inv[n_lines : n_lines + k, n_lines : n_lines + k] * (ssr_w / (n_used - m))
    if k == N_SHARED:
        return np.asarray(block, dtype=np.float64)
    out[np.ix_(rows, rows)] = block
    return out


def weighted_ssr(
    iq: FloatArray,
    r: FloatArray,
    labels: IntArray,
    model: SharedModel,
    height_m: float,
    max_range_m: float,
) -> tuple[float, int]:
    """Return the weighted squared residuals (metres^2 / metres^2) and point count of a model.

    Residuals are lateral (metres) with the refit's weight ``1 / max(x, NEAR_WEIGHT_M)``;
    unassigned points and points beyond ``max_range_m`` are left out, as in the refit.
    """
    keep = labels >= 0
    iq, r, lab = iq[keep], r[keep], labels[keep]
    den = road_den(iq + model.b / height_m, model.c / height_m)
    ok = den >= 1.0 / max_range_m
    x = 1.0 / den[ok]
    resid = r[ok] * x - (model.offsets[lab[ok]] + x * (model.a1 + model.a2 * x))
    w = 1.0 / np.maximum(x, NEAR_WEIGHT_M)
    return float(np.sum((w * resid) ** 2)), int(ok.sum())


def _solve(design: FloatArray, target: FloatArray, sqrt_w: FloatArray) -> FloatArray:
    """Solve the weighted least-squares problem ``design @ p ~ target`` (small ridge)."""
    a = design * sqrt_w[:, None]
    t = target * sqrt_w
    normal = a.T @ a
    normal[np.diag_indices_from(normal)] += 1e-9 * (np.trace(normal) / normal.shape[0] + 1.0)
    out = np.linalg.solve(normal, a.T @ t)
    return np.asarray(out, dtype=np.float64)


def refit_shared(
    iq: FloatArray,
    r: FloatArray,
    labels: IntArray,
    n_lines: int,
    start: SharedModel,
    height_m: float,
    order: int,
    fit_slope: bool,
    slope_bound: float,
    max_range_m: float,
    iterations: int = 6,
    compiled: bool = False,
    vertical_bound: float = 0.0,
) -> SharedModel:
    """Refit shared heading, curvature, slope and per-line offsets to assigned points.

    Args:
        iq: Inverse flat-ground forward distance of each point's ray, 1/m.
        r: Lateral slope ``dy / dx`` of each point's ray.
        labels: Line index of each point (-1: unassigned, ignored).
        n_lines: Number of lines.
        start: Starting parameters (from Nelder-Mead).
        height_m: Camera height, metres.
        order: Polynomial order (1 fixes ``a2 = 0``).
        fit_slope: Estimate ``b`` (needs two lines or more); else keep ``start.b``.
        slope_bound: Bound on ``|b|``.
        max_range_m: Points whose road intersection is farther are ignored, metres.
        iterations: Gauss-Newton iterations at most.
        compiled: Accumulate the normal equations with a numba kernel (one pass, no design
            matrix) instead of numpy; same result to rounding.
        vertical_bound: Bound on ``|c|`` (1/m); > 0 also estimates ``c`` (needs two lines or
            more), 0 keeps ``start.c``.
    """
    refit = _refit_compiled if compiled else _refit_numpy
    return refit(
        iq, r, labels, n_lines, start, height_m, order, fit_slope, slope_bound, max_range_m,
        iterations, vertical_bound,
    )  # fmt: skip


def _refit_numpy(
    iq: FloatArray,
    r: FloatArray,
    labels: IntArray,
    n_lines: int,
    start: SharedModel,
    height_m: float,
    order: int,
    fit_slope: bool,
    slope_bound: float,
    max_range_m: float,
    iterations: int,
    vertical_bound: float,
) -> SharedModel:
    """:func:`refit_shared` on a numpy design matrix (the reference of ``_refit_compiled``)."""
    keep = labels >= 0
    iq, r, lab = iq[keep], r[keep], labels[keep]
    if iq.size < n_lines + order + 1:
        return start
    onehot = np.zeros((iq.size, n_lines))
    onehot[np.arange(iq.size), lab] = 1.0
    a1, a2, b, c = start.a1, start.a2, start.b, start.c
    offsets = start.offsets
    normal = np.zeros((1, 1))
    fit_slope = fit_slope and n_lines >= 2
    fit_vertical = vertical_bound > 0 and n_lines >= 2
    for _ in range(iterations if fit_slope or fit_vertical else 1):
        design, y, sqrt_w = _design(
            iq, r, onehot, (a1, a2, b, c), height_m, max_range_m, order, fit_slope, fit_vertical
        )
        p = _solve(design, y, sqrt_w)
        weighted = design * sqrt_w[:, None]
        normal = weighted.T @ weighted
        offsets = p[:n_lines]
        a1 = float(p[n_lines])
        a2 = float(p[n_lines + 1]) if order == 2 else 0.0
        if not (fit_slope or fit_vertical):
            break
        k = n_lines + (2 if order == 2 else 1)
        b, c, done = _road_step(p[k:], (b, c), fit_slope, slope_bound, fit_vertical, vertical_bound)
        if done:
            break
    model = SharedModel(a1, a2, b, np.asarray(offsets, dtype=np.float64), c)
    return _with_cov(model, normal, iq, r, lab, n_lines, order, fit_slope, height_m, max_range_m)


def _design(
    iq: FloatArray,
    r: FloatArray,
    onehot: FloatArray,
    shared: tuple[float, float, float, float],
    height_m: float,
    max_range_m: float,
    order: int,
    fit_slope: bool,
    fit_vertical: bool,
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """One Gauss-Newton step's design matrix at ``(a1, a2, b, c)``, target ``y`` and weights.

    Columns: offsets..., ``a1``, [``a2``], [``b``], [``c``] (``b`` and ``c`` linearised).
    """
    a1, a2, b, c = shared
    den0 = iq + b / height_m
    den = road_den(den0, c / height_m)
    ok = den >= 1.0 / max_range_m
    x = 1.0 / np.where(ok, den, 1.0)
    y = r * x
    sqrt_w = np.where(ok, 1.0 / np.maximum(x, NEAR_WEIGHT_M), 0.0)
    cols = [onehot, x[:, None]]
    if order == 2:
        cols.append((x * x)[:, None])
    if c == 0.0:
        dx = -x * x / height_m
        dy = -x * y / height_m
        g = (a1 + 2.0 * a2 * x) * dx - dy
    else:
        s = np.maximum(2.0 * den - den0, 1e-9)
        g = (a1 + 2.0 * a2 * x - r) * (-x / (height_m * s))
    if fit_slope:
        cols.append(g[:, None])
    if fit_vertical:
        cols.append((g * x)[:, None])
    return np.hstack(cols), y, sqrt_w


def _road_step(
    steps: FloatArray,
    road: tuple[float, float],
    fit_slope: bool,
    slope_bound: float,
    fit_vertical: bool,
    vertical_bound: float,
) -> tuple[float, float, bool]:
    """Step the road's ``b`` and ``c`` by ``steps`` (those fitted, bounded); True once settled."""
    b, c = road
    done = True
    k = 0
    if fit_slope:
        b_new = float(np.clip(b + float(steps[k]), -slope_bound, slope_bound))
        done = abs(b_new - b) < 1e-7
        b = b_new
        k += 1
    if fit_vertical:
        c_new = float(np.clip(c + float(steps[k]), -vertical_bound, vertical_bound))
        done = done and abs(c_new - c) < 1e-9
        c = c_new
    return b, c, done


def _with_cov(
    model: SharedModel,
    normal: FloatArray,
    iq: FloatArray,
    r: FloatArray,
    labels: IntArray,
    n_lines: int,
    order: int,
    fit_slope: bool,
    height_m: float,
    max_range_m: float,
    compiled: bool = False,
) -> SharedModel:
    """Attach :func:`shared_covariance` (from the last Gauss-Newton step) to ``model``."""
    if compiled:
        from superlane_tools.lanes._refit_kernels import refit_ssr

        ssr, n_used = refit_ssr(
            iq, r, labels, model.offsets, model.a1, model.a2, model.b, model.c,
            1.0 / height_m, 1.0 / max_range_m, NEAR_WEIGHT_M,
        )  # fmt: skip
    else:
        ssr, n_used = weighted_ssr(iq, r, labels, model, height_m, max_range_m)
    cov = shared_covariance(normal, ssr, n_used, n_lines, order, fit_slope)
    return model._replace(cov=cov)


def _refit_compiled(
    iq: FloatArray,
    r: FloatArray,
    labels: IntArray,
    n_lines: int,
    start: SharedModel,
    height_m: float,
    order: int,
    fit_slope: bool,
    slope_bound: float,
    max_range_m: float,
    iterations: int,
    vertical_bound: float,
) -> SharedModel:
    """:func:`refit_shared` on normal equations accumulated by ``_refit_kernels.refit_normal``."""
    if int((labels >= 0).sum()) < n_lines + order + 1:
        return start
    fit_slope = fit_slope and n_lines >= 2
    a1, a2, b, c, offsets, normal = _gauss_newton(
        iq, r, labels, n_lines, start, 1.0 / height_m, 1.0 / max_range_m, order, fit_slope,
        slope_bound, vertical_bound if n_lines >= 2 else 0.0, iterations,
    )  # fmt: skip
    model = SharedModel(
        float(a1), float(a2), float(b), np.asarray(offsets, dtype=np.float64), float(c)
    )
    return _with_cov(
        model, np.asarray(normal), iq, r, labels, n_lines, order, fit_slope, height_m,
        max_range_m, compiled=True,
    )  # fmt: skip


def _gauss_newton(
    iq: FloatArray,
    r: FloatArray,
    labels: IntArray,
    n_lines: int,
    start: SharedModel,
    inv_h: float,
    min_den: float,
    order: int,
    fit_slope: bool,
    slope_bound: float,
    vertical_bound: float,
    iterations: int,
) -> tuple[float, float, float, float, FloatArray, FloatArray]:
    """Run the Gauss-Newton loop of :func:`refit_shared` on the compiled point passes.

    The loop itself is a handful of scalar steps per frame, so it stays in Python (compiling it
    as one more kernel cost 1.5 s or more of the first run); each step's pass over the points
    (``refit_normal``) and its small solve (``solve_ridged``) are the compiled kernels. Same
    arithmetic, in the same order, as a compiled loop: results are identical.

    Returns:
        ``a1, a2, b, c, offsets`` and the last step's normal matrix (for the covariance).
    """
    from superlane_tools.lanes._refit_kernels import refit_normal, solve_ridged

    fit_vertical = vertical_bound > 0
    a1, a2, b, cv = float(start.a1), float(start.a2), float(start.b), float(start.c)
    offsets: FloatArray = np.empty(n_lines)
    normal: FloatArray = np.zeros((1, 1))
    for _ in range(iterations if fit_slope or fit_vertical else 1):
        normal, rhs = refit_normal(
            iq, r, labels, n_lines, a1, a2, b, cv, inv_h, min_den, order, fit_slope,
            fit_vertical, NEAR_WEIGHT_M,
        )  # fmt: skip
        p = solve_ridged(normal, rhs)
        offsets = p[:n_lines].copy()
        a1 = float(p[n_lines])
        a2 = float(p[n_lines + 1]) if order == 2 else 0.0
        if not (fit_slope or fit_vertical):
            break
        done = True
        k = n_lines + (2 if order == 2 else 1)
        if fit_slope:
            b_new = min(max(b + float(p[k]), -slope_bound), slope_bound)
            done = abs(b_new - b) < 1e-7
            b = b_new
            k += 1
        if fit_vertical:
            c_new = min(max(cv + float(p[k]), -vertical_bound), vertical_bound)
            done = done and abs(c_new - cv) < 1e-9
            cv = c_new
        if done:
            break
    return a1, a2, b, cv, offsets, normal


class LocalCorrection(NamedTuple):
    """A line's own quadratic correction ``c0 + c1 x + c2 x^2`` (metres, rad, 1/m)."""

    c0: float
    c1: float
    c2: float


def local_correction(
    x: FloatArray,
    residual: FloatArray,
    order: int,
    bound_m: float,
) -> LocalCorrection:
    """Fit a bounded correction to one line's residuals from the shared model.

    The correction's order grows with the line's support span (offset only below 5 m, plus a
    heading term below 15 m) and its largest displacement over the support is scaled down to
    ``bound_m``, so a line can follow a merge or split without leaving the shared model.

    Args:
        x: Corrected forward distances of the line's points, metres.
        residual: The points' lateral residuals from the shared line, metres.
        order: Highest polynomial order allowed (1 or 2).
        bound_m: Largest correction over ``[min(x), max(x)]``, metres.
    """
    if x.size < 8 or bound_m <= 0:
        return LocalCorrection(0.0, 0.0, 0.0)
    span = float(x.max() - x.min())
    k = _correction_order(span, order)
    design = np.stack([x**j for j in range(k + 1)], axis=1)
    sqrt_w = 1.0 / np.maximum(x, NEAR_WEIGHT_M)
    coef = np.zeros(3)
    coef[: k + 1] = _solve(design, residual, sqrt_w)
    return _bounded(coef, float(x.min()), float(x.max()), bound_m)


def _correction_order(span_m: float, order: int) -> int:
    return 0 if span_m < 5.0 else (1 if span_m < 15.0 or order == 1 else 2)


def _bounded(coef: FloatArray, x_min: float, x_max: float, bound_m: float) -> LocalCorrection:
    """Scale ``coef`` down so that the correction stays within ``bound_m`` over the support."""
    grid = np.linspace(x_min, x_max, 16)
    worst = float(np.max(np.abs(coef[0] + grid * (coef[1] + grid * coef[2]))))
    if worst > bound_m:
        coef = coef * (bound_m / worst)
    return LocalCorrection(float(coef[0]), float(coef[1]), float(coef[2]))


def local_correction_from_sums(
    sums_x: FloatArray, sums_r: FloatArray, order: int, bound_m: float
) -> LocalCorrection:
    """Fit :func:`local_correction` from a line's accumulated weighted sums.

    Args:
        sums_x: ``sum w x^j`` for ``j = 0..4`` with ``w = 1 / max(x, NEAR_WEIGHT_M)^2``.
        sums_r: ``sum w x^j residual`` for ``j = 0..2``, then the point count, min and max
            of ``x`` (metres), as ``_kernels.line_sums`` returns them.
        order: Highest polynomial order allowed (1 or 2).
        bound_m: Largest correction over the line's support, metres.
    """
    count, x_min, x_max = float(sums_r[3]), float(sums_r[4]), float(sums_r[5])
    if count < 8 or bound_m <= 0:
        return LocalCorrection(0.0, 0.0, 0.0)
    k = _correction_order(x_max - x_min, order)
    idx = np.arange(k + 1)
    normal = np.asarray(sums_x, dtype=np.float64)[idx[:, None] + idx[None, :]]
    normal[np.diag_indices_from(normal)] += 1e-9 * (np.trace(normal) / normal.shape[0] + 1.0)
    coef = np.zeros(3)
    coef[: k + 1] = np.linalg.solve(normal, np.asarray(sums_r[: k + 1], dtype=np.float64))
    return _bounded(coef, x_min, x_max, bound_m)


def local_corrections_compiled(
    sums_x: FloatArray, sums_r: FloatArray, order: int, bound_m: float
) -> FloatArray:
    """Return each line's bounded correction ``(c0, c1, c2)`` from ``_kernels.line_sums``.

    As :func:`local_correction`: the order grows with the support span, and the correction is
    scaled into ``+-bound_m`` over the support. A few scalar steps per line, so the loop stays
    in Python (one kernel less to compile on the first run) around the compiled
    ``solve_ridged``; the arithmetic and its order are those of the former compiled loop.
    """
    from superlane_tools.lanes._refit_kernels import solve_ridged

    n_lines = sums_x.shape[0]
    out = np.zeros((n_lines, 3))
    for n in range(n_lines):
        count, x_min, x_max = float(sums_r[n, 3]), float(sums_r[n, 4]), float(sums_r[n, 5])
        if count < 8 or bound_m <= 0:
            continue
        span = x_max - x_min
        k = 0 if span < 5.0 else (1 if span < 15.0 or order == 1 else 2)
        normal = np.empty((k + 1, k + 1))
        for i in range(k + 1):
            normal[i] = sums_x[n, i : i + k + 1]
        coef = solve_ridged(normal, sums_r[n, : k + 1].copy())
        worst = 0.0
        for g in range(16):
            x = x_min + (x_max - x_min) * g / 15.0
            v = float(coef[0])
            if k >= 1:
                v += x * (float(coef[1]) + (x * float(coef[2]) if k == 2 else 0.0))
            worst = max(worst, abs(v))
        scale = bound_m / worst if worst > bound_m else 1.0
        out[n, : k + 1] = coef * scale
    return out
