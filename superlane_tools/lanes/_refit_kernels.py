"""Numba kernels of the multi-lane fit's least-squares refit: normal equations, solve, residuals.

The refit half of :mod:`superlane_tools.lanes._kernels` (same ``_jit`` cache, same rules): they
mirror the numpy reference in :mod:`superlane_tools.lanes._refit` operation for operation.
:mod:`superlane_tools.lanes.kernel_cache` compiles both modules and marks the cache complete
for both sources.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from superlane_tools.lanes._kernels import _jit, road_den


@_jit
def refit_normal(
    iq: Any,
    r: Any,
    labels: Any,
    n_lines: int,
    a1: float,
    a2: float,
    b: float,
    cv: float,
    inv_h: float,
    min_den: float,
    order: int,
    fit_slope: bool,
    fit_vertical: bool,
    near_m: float,
) -> tuple[Any, Any]:
    """Return the weighted normal equations of one Gauss-Newton step of ``_refit.refit_shared``.

    Columns: one offset per line, ``x``, ``x^2`` (order 2), the slope derivative (when
    ``fit_slope``), the vertical-curvature derivative (when ``fit_vertical``); target ``y``;
    weights ``1 / max(x, near_m)^2``; unassigned points and points beyond range are left out.
    """
    m = n_lines + 1 + (1 if order == 2 else 0) + (1 if fit_slope else 0)
    m += 1 if fit_vertical else 0
    normal = np.zeros((m, m))
    rhs = np.zeros(m)
    col = np.zeros(m - n_lines)
    c = b * inv_h
    c_h = cv * inv_h
    for i in range(iq.size):
        n = labels[i]
        if n < 0:
            continue
        den = road_den(iq[i], c, c_h)
        if den < min_den:
            continue
        x = 1.0 / den
        y = r[i] * x
        w = 1.0 / max(x, near_m)
        w *= w
        col[0] = x
        k = 1
        if order == 2:
            col[1] = x * x
            k = 2
        if c_h == 0.0:
            g = (a1 + 2.0 * a2 * x) * (-x * x * inv_h) - (-x * y * inv_h)
        else:
            # dx/db = -x / (h s), s = sqrt(den^2 + 4 c / h) = 2 / x - (iq + b / h).
            s = max(2.0 * den - (iq[i] + c), 1e-9)
            g = (a1 + 2.0 * a2 * x - r[i]) * (-x * inv_h / s)
        if fit_slope:
            col[k] = g
            k += 1
        if fit_vertical:
            col[k] = g * x  # dx/dc = x dx/db
        normal[n, n] += w
        rhs[n] += w * y
        for j in range(m - n_lines):
            wj = w * col[j]
            normal[n, n_lines + j] += wj
            rhs[n_lines + j] += wj * y
            for q in range(j, m - n_lines):
                normal[n_lines + j, n_lines + q] += wj * col[q]
    for j in range(n_lines, m):
        for q in range(j + 1, m):
            normal[q, j] = normal[j, q]
    for n in range(n_lines):
        for j in range(n_lines, m):
            normal[j, n] = normal[n, j]
    return normal, rhs


@_jit
def solve_ridged(normal: Any, rhs: Any) -> Any:
    """Solve ``(normal + ridge I) p = rhs`` for a small symmetric positive semi-definite matrix.

    The ridge ``1e-9 * (trace / m + 1)`` matches ``_refit._solve``; Cholesky in place of LU (the
    ridged matrix is positive definite).
    """
    m = rhs.size
    a = normal.copy()
    tr = 0.0
    for j in range(m):
        tr += a[j, j]
    ridge = 1e-9 * (tr / m + 1.0)
    for j in range(m):
        a[j, j] += ridge
    for j in range(m):
        s = a[j, j]
        for k in range(j):
            s -= a[j, k] * a[j, k]
        d = math.sqrt(max(s, 1e-300))
        a[j, j] = d
        for i in range(j + 1, m):
            s = a[i, j]
            for k in range(j):
                s -= a[i, k] * a[j, k]
            a[i, j] = s / d
    y = np.empty(m)
    for i in range(m):
        s = rhs[i]
        for k in range(i):
            s -= a[i, k] * y[k]
        y[i] = s / a[i, i]
    p = np.empty(m)
    for i in range(m - 1, -1, -1):
        s = y[i]
        for k in range(i + 1, m):
            s -= a[k, i] * p[k]
        p[i] = s / a[i, i]
    return p


@_jit
def refit_ssr(
    iq: Any,
    r: Any,
    labels: Any,
    offsets: Any,
    a1: float,
    a2: float,
    b: float,
    cv: float,
    inv_h: float,
    min_den: float,
    near_m: float,
) -> tuple[float, int]:
    """Return ``_refit.weighted_ssr``: weighted squared lateral residuals and point count."""
    ssr = 0.0
    count = 0
    b_h = b * inv_h
    c_h = cv * inv_h
    for i in range(iq.size):
        n = labels[i]
        if n < 0:
            continue
        den = road_den(iq[i], b_h, c_h)
        if den < min_den:
            continue
        x = 1.0 / den
        res = (r[i] * x - (offsets[n] + x * (a1 + a2 * x))) / max(x, near_m)
        ssr += res * res
        count += 1
    return ssr, count


def signatures() -> dict[Any, tuple[Any, ...]]:
    """Each kernel of this module with the argument types the fit passes it."""
    from numba import types

    f8, i8, flag = types.float64, types.int64, types.boolean
    a, a2, ia = types.float64[::1], types.float64[:, ::1], types.intp[::1]
    return {
        refit_normal: (a, a, ia, i8, f8, f8, f8, f8, f8, f8, i8, flag, flag, f8),
        solve_ridged: (a2, a),
        refit_ssr: (a, a, ia, a, f8, f8, f8, f8, f8, f8, f8),
    }
