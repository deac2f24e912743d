"""Numba kernels of the multi-lane fit: the cost J, its batched form, Nelder-Mead, point passes.

The least-squares refit's kernels are in :mod:`superlane_tools.lanes._refit_kernels`.

Each kernel makes one pass over the points without temporaries; they mirror the pure-numpy
reference in :mod:`superlane_tools.lanes.cost` (same formulas, same operation order) and
scipy's bounded Nelder-Mead step for step, so both backends agree to rounding.

Imported lazily (numba's import costs ~0.5 s and the first call compiles for seconds): only
functions that run a fit import this module. Compiled kernels are cached on disk in the user's
cache folder (:func:`kernel_cache_dir`: ``$SLT_CACHE_DIR/numba``, else
``$XDG_CACHE_HOME/superlane-tools/numba``, else ``~/.cache/superlane-tools/numba``), so a
second process loads them instead of compiling, also when the package is installed read-only.
Where no cache folder is writable the kernels are compiled in memory each process. The first
compilation in a process prints one line to stderr, :data:`COMPILE_NOTE`.

The cost configuration travels as one float array ``cfg`` (see the ``CFG_*`` indices). The road
is ``z = b x + c x^2`` ahead of the camera foot; ``c = 0`` (the paper's linear road) takes the
exact flat-slope path of :func:`road_den`.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Callable
from typing import Any, TypeVar, cast

import numba
import numpy as np
from numba.core import event

from superlane_tools.lanes._cache_folder import COMPILE_NOTE, kernel_cache_dir, writable

F = TypeVar("F", bound=Callable[..., Any])

CFG_INV_H = 0
"""``1 / camera height`` (1/m)."""
CFG_MIN_DEN = 1
"""``1 / max_range_m``: smallest valid ray denominator (1/m)."""
CFG_POS_SCALE = 2
"""``1 / bin width`` (1/m)."""
CFG_POS_SHIFT = 3
"""Histogram slot of residual 0 (slot k + 1 holds bin k)."""
CFG_N_BINS = 4
"""Number of histogram bins."""
CFG_KAPPA = 5
"""Weight of the out-of-range penalty of Eq. 2."""
CFG_LAMBDA = 6
"""Weight of J1 in Eq. 3 (0: no road term)."""
CFG_INV_SIGMA = 7
"""``1 / sigma_d`` of Eq. 1 (1/m)."""
CFG_JACOBIAN = 8
"""Weight of the mean log inverse distance of the binned points (1: entropy per pixel, 0: off)."""
CFG_SIZE = 9


_CACHE_DIR = kernel_cache_dir()
_CACHE_OK = writable(_CACHE_DIR)


_KERNEL_MODULES = (__name__, "superlane_tools.lanes._refit_kernels")


class _CompileNote(event.Listener):
    """Print :data:`COMPILE_NOTE` once, when numba starts compiling a kernel of the fit."""

    printed = False

    def on_start(self, event: Any) -> None:
        func = getattr(event.data.get("dispatcher"), "py_func", None)
        if not _CompileNote.printed and getattr(func, "__module__", None) in _KERNEL_MODULES:
            _CompileNote.printed = True
            print(COMPILE_NOTE, file=sys.stderr, flush=True)

    def on_end(self, event: Any) -> None:
        """Nothing to do when a compilation ends."""


event.register("numba:compile", _CompileNote())  # type: ignore[no-untyped-call]


def _jit(func: F) -> F:
    """Compile ``func`` lazily, cached in :func:`kernel_cache_dir` (in memory if unwritable)."""
    options: dict[str, Any] = {"fastmath": False, "nogil": True}
    if not _CACHE_OK:
        return cast("F", numba.njit(cache=False, **options)(func))
    config: Any = numba.config
    previous = config.CACHE_DIR
    config.CACHE_DIR = str(_CACHE_DIR)  # read once, when the dispatcher finds its cache
    try:
        return cast("F", numba.njit(cache=True, **options)(func))
    except RuntimeError:  # numba: "cannot cache function ...: no locator available"
        return cast("F", numba.njit(cache=False, **options)(func))
    finally:
        config.CACHE_DIR = previous


@_jit
def road_den(iq: float, b_h: float, c_h: float) -> float:
    """Return ``1 / x`` of a ray's nearer intersection with the road ``z = b x + c x^2`` (1/m).

    ``b_h = b / h`` and ``c_h = c / h``; the ray ``(iq, .)`` meets the road where
    ``c_h x^2 + (iq + b_h) x - 1 = 0``, whose nearer positive root is
    ``x = 2 / (den + sqrt(den^2 + 4 c_h))`` with ``den = iq + b_h`` (no cancellation as
    ``c -> 0``; ``c = 0`` returns ``den`` exactly). A ray that passes over a crest returns -1.
    Callers treat values below ``1 / max_range`` as out of range.
    """
    den = iq + b_h
    if c_h == 0.0:
        return den
    disc = den * den + 4.0 * c_h
    if disc < 0.0:
        return -1.0
    return 0.5 * (den + math.sqrt(disc))


@_jit
def lane_cost(
    iq: Any, r: Any, a1: float, a2: float, b: float, cv: float, cfg: Any, hist: Any
) -> float:
    """Return J2 (Eq. 2): soft-binned entropy of the residuals + kappa * N_l / n_l.

    ``cv`` is the vertical curvature term ``c`` (1/m) of the road ``z = b x + c x^2``.
    ``hist`` is scratch space of ``n_bins + 3`` floats (slot 0 and slots above ``n_bins``
    collect the out-of-range residuals). With ``cfg[CFG_JACOBIAN] = 1`` the entropy is that of
    the residuals per image pixel: the binned points' mean ``log(1 / x)`` is added (see
    :class:`superlane_tools.lanes.cost.CostFunction`).
    """
    n_bins = int(cfg[CFG_N_BINS])
    penalty: float = cfg[CFG_KAPPA] * iq.size
    c = b * cfg[CFG_INV_H]
    c_h = cv * cfg[CFG_INV_H]
    min_den = cfg[CFG_MIN_DEN]
    scale = cfg[CFG_POS_SCALE]
    shift = cfg[CFG_POS_SHIFT]
    jacobian: float = cfg[CFG_JACOBIAN]
    top = n_bins + 1.0
    for k in range(n_bins + 3):
        hist[k] = 0.0
    log_den = 0.0
    for i in range(iq.size):
        den = road_den(iq[i], c, c_h)
        if den < min_den:
            pos = 0.0
        else:
            x = 1.0 / den
            pos = x * (r[i] - a1 - a2 * x) * scale + shift
            if pos < 0.0:
                pos = 0.0
            elif pos > top:
                pos = top
        k = int(pos)
        frac = pos - k
        hist[k] += 1.0 - frac
        hist[k + 1] += frac
        if jacobian != 0.0 and 0.0 < pos < top:
            binned = (1.0 - frac if k >= 1 else 0.0) + (frac if k < n_bins else 0.0)
            log_den += binned * math.log(den)
    n_in = 0.0
    for k in range(1, n_bins + 1):
        n_in += hist[k]
    if n_in <= 0.0:
        return math.log(n_bins) + penalty
    inv_n = 1.0 / n_in
    h = 0.0
    for k in range(1, n_bins + 1):
        if hist[k] > 0.0:
            p = hist[k] * inv_n
            h -= p * math.log(p)
    return h + jacobian * log_den * inv_n + penalty / n_in


@_jit
def road_cost(
    riq: Any, rr: Any, a1: float, a2: float, b: float, a0c: float, cv: float, cfg: Any
) -> float:
    """Return J1 (Eq. 1): minus the Gaussian closeness of road points to the centre line."""
    c = b * cfg[CFG_INV_H]
    c_h = cv * cfg[CFG_INV_H]
    min_den = cfg[CFG_MIN_DEN]
    inv_sigma = cfg[CFG_INV_SIGMA]
    s = 0.0
    for i in range(riq.size):
        den = road_den(riq[i], c, c_h)
        if den >= min_den:
            x = 1.0 / den
            d = (x * (rr[i] - a1 - a2 * x) - a0c) * inv_sigma
            s += math.exp(-(d * d))
    return -s


@_jit
def total_cost(iq: Any, r: Any, riq: Any, rr: Any, theta: Any, cfg: Any, hist: Any) -> float:
    """Return J = lambda * J1 + J2 (Eq. 3) for ``theta = (a1, a2, b, a0c[, c])``."""
    cv = theta[4] if theta.size > 4 else 0.0
    cost = 0.0
    if iq.size:
        cost = lane_cost(iq, r, theta[0], theta[1], theta[2], cv, cfg, hist)
    if riq.size:
        cost += cfg[CFG_LAMBDA] * road_cost(
            riq, rr, theta[0], theta[1], theta[2], theta[3], cv, cfg
        )
    return cost


@_jit
def batch_cost(iq: Any, r: Any, riq: Any, rr: Any, thetas: Any, cfg: Any, hist: Any) -> Any:
    """Return J for each row of ``(P, 4)`` or ``(P, 5)`` parameter vectors (the initial grid)."""
    out = np.empty(thetas.shape[0])
    for j in range(thetas.shape[0]):
        out[j] = total_cost(iq, r, riq, rr, thetas[j], cfg, hist)
    return out


@_jit
def _eval_scaled(
    v: Any,
    base: Any,
    free: Any,
    scale: Any,
    iq: Any,
    r: Any,
    riq: Any,
    rr: Any,
    cfg: Any,
    hist: Any,
) -> float:
    theta = base.copy()
    for k in range(free.size):
        theta[free[k]] = v[k] * scale[k]
    return total_cost(iq, r, riq, rr, theta, cfg, hist)


@_jit
def _set_row(sim: Any, j: int, values: Any) -> None:
    """``sim[j] = values``, element by element (see :func:`_sort_simplex` for why)."""
    for k in range(values.size):
        sim[j, k] = values[k]


@_jit
def _sort_simplex(sim: Any, fsim: Any) -> None:
    """Stable insertion sort of the simplex by cost (numpy's argsort on <= 16 items).

    Rows are copied element by element: whole-row assignment makes numba compile its generic
    broadcasting setitem (about 2 s of the first run's kernel compilation), for 2-5 numbers.
    """
    n_dim = sim.shape[1]
    row = np.empty(n_dim)
    for i in range(1, fsim.size):
        f = fsim[i]
        for k in range(n_dim):
            row[k] = sim[i, k]
        j = i - 1
        while j >= 0 and fsim[j] > f:
            fsim[j + 1] = fsim[j]
            for k in range(n_dim):
                sim[j + 1, k] = sim[j, k]
            j -= 1
        fsim[j + 1] = f
        for k in range(n_dim):
            sim[j + 1, k] = row[k]


@_jit
def _clip(v: Any, lo: Any, hi: Any) -> None:
    for k in range(v.size):
        v[k] = min(max(v[k], lo[k]), hi[k])


@_jit
def nelder_mead(
    sim0: Any,
    base: Any,
    free: Any,
    scale: Any,
    lo: Any,
    hi: Any,
    xatol: float,
    fatol: float,
    max_iterations: int,
    iq: Any,
    r: Any,
    riq: Any,
    rr: Any,
    cfg: Any,
    hist: Any,
) -> tuple[Any, float, int, int, bool]:
    """Minimise J over ``theta[free] = v * scale`` with bounded Nelder-Mead.

    The same algorithm as ``scipy.optimize.minimize(method="Nelder-Mead", bounds=...,
    initial_simplex=sim0)``: standard coefficients (1, 2, 0.5, 0.5), every trial point clipped
    to ``[lo, hi]``, stop when the simplex spans at most ``xatol`` and its costs ``fatol``.

    Returns:
        Best ``v``, its cost, iterations, cost evaluations and whether it converged.
    """
    n = sim0.shape[1]
    sim = sim0.copy()
    for j in range(n + 1):
        for k in range(n):
            if sim[j, k] > hi[k]:
                sim[j, k] = 2.0 * hi[k] - sim[j, k]
        _clip(sim[j], lo, hi)
    fsim = np.empty(n + 1)
    for j in range(n + 1):
        fsim[j] = _eval_scaled(sim[j], base, free, scale, iq, r, riq, rr, cfg, hist)
    nfev = n + 1
    _sort_simplex(sim, fsim)
    xbar = np.empty(n)
    trial = np.empty(n)
    iterations = 1
    while iterations < max_iterations:
        spread = 0.0
        fspread = 0.0
        for j in range(1, n + 1):
            fspread = max(fspread, abs(fsim[0] - fsim[j]))
            for k in range(n):
                spread = max(spread, abs(sim[j, k] - sim[0, k]))
        if spread <= xatol and fspread <= fatol:
            break
        for k in range(n):
            acc = 0.0
            for j in range(n):
                acc += sim[j, k]
            xbar[k] = acc / n
        for k in range(n):
            trial[k] = 2.0 * xbar[k] - sim[n, k]
        _clip(trial, lo, hi)
        fxr = _eval_scaled(trial, base, free, scale, iq, r, riq, rr, cfg, hist)
        nfev += 1
        xr = trial.copy()
        if fxr < fsim[0]:
            for k in range(n):
                trial[k] = 3.0 * xbar[k] - 2.0 * sim[n, k]
            _clip(trial, lo, hi)
            fxe = _eval_scaled(trial, base, free, scale, iq, r, riq, rr, cfg, hist)
            nfev += 1
            if fxe < fxr:
                _set_row(sim, n, trial)
                fsim[n] = fxe
            else:
                _set_row(sim, n, xr)
                fsim[n] = fxr
        elif fxr < fsim[n - 1]:
            _set_row(sim, n, xr)
            fsim[n] = fxr
        else:
            shrink = False
            if fxr < fsim[n]:
                for k in range(n):
                    trial[k] = 1.5 * xbar[k] - 0.5 * sim[n, k]
                _clip(trial, lo, hi)
                fxc = _eval_scaled(trial, base, free, scale, iq, r, riq, rr, cfg, hist)
                nfev += 1
                if fxc <= fxr:
                    _set_row(sim, n, trial)
                    fsim[n] = fxc
                else:
                    shrink = True
            else:
                for k in range(n):
                    trial[k] = 0.5 * xbar[k] + 0.5 * sim[n, k]
                _clip(trial, lo, hi)
                fxcc = _eval_scaled(trial, base, free, scale, iq, r, riq, rr, cfg, hist)
                nfev += 1
                if fxcc < fsim[n]:
                    _set_row(sim, n, trial)
                    fsim[n] = fxcc
                else:
                    shrink = True
            if shrink:
                for j in range(1, n + 1):
                    for k in range(n):
                        sim[j, k] = sim[0, k] + 0.5 * (sim[j, k] - sim[0, k])
                    _clip(sim[j], lo, hi)
                    fsim[j] = _eval_scaled(sim[j], base, free, scale, iq, r, riq, rr, cfg, hist)
                    nfev += 1
        iterations += 1
        _sort_simplex(sim, fsim)
    return sim[0].copy(), fsim[0], iterations, nfev, iterations < max_iterations


@_jit
def ray_slopes(
    xn: Any, yn: Any, rot: Any, height_m: float, reach: float, min_den: float, max_den: float
) -> tuple[Any, Any, Any]:
    """Return ``iq``, ``r`` of each normalised pixel ray and whether it is usable.

    ``iq = -dz / (h dx)`` (1/m) and ``r = dy / dx`` of the vehicle-frame ray
    ``rot @ (xn, yn, 1)``; a ray is usable when it points forward and meets the road within
    ``[1 / max_den, 1 / min_den]`` metres for some slope within ``reach * h`` (with a vertical
    curvature term, ``reach`` covers the slope ``b + c x`` at the farthest range).
    """
    n = xn.size
    iq = np.empty(n)
    r = np.empty(n)
    keep = np.zeros(n, dtype=np.bool_)
    for i in range(n):
        dx = rot[0, 0] * xn[i] + rot[0, 1] * yn[i] + rot[0, 2]
        dy = rot[1, 0] * xn[i] + rot[1, 1] * yn[i] + rot[1, 2]
        dz = rot[2, 0] * xn[i] + rot[2, 1] * yn[i] + rot[2, 2]
        norm = math.sqrt(dx * dx + dy * dy + dz * dz)
        if dx > 1e-9 * norm:
            q = -dz / (height_m * dx)
            iq[i] = q
            r[i] = dy / dx
            keep[i] = (q + reach >= min_den) and (q - reach <= max_den)
        else:
            iq[i] = -1.0 / height_m
            r[i] = 0.0
    return iq, r, keep


@_jit
def assign_points(
    iq: Any,
    r: Any,
    a1: float,
    a2: float,
    b: float,
    cv: float,
    inv_h: float,
    min_den: float,
    offsets: Any,
    radius_m: float,
    radius_per_m: float,
) -> tuple[Any, Any, Any]:
    """Return forward distance ``x`` (NaN: invalid), residual and nearest line of each point.

    Points lie on the road ``z = b x + cv x^2``. A point belongs to the nearest offset within
    ``radius_m + radius_per_m * x`` (else -1).
    """
    n = iq.size
    x_out = np.empty(n)
    res_out = np.empty(n)
    labels = np.empty(n, dtype=np.intp)  # not np.full: one allocator less to compile
    c = b * inv_h
    c_h = cv * inv_h
    for i in range(n):
        labels[i] = -1
        den = road_den(iq[i], c, c_h)
        if den < min_den:
            x_out[i] = np.nan
            res_out[i] = np.nan
            continue
        x = 1.0 / den
        res = r[i] * x - x * (a1 + a2 * x)
        x_out[i] = x
        res_out[i] = res
        best = np.inf
        for j in range(offsets.size):
            d = abs(res - offsets[j])
            if d < best:
                best = d
                labels[i] = j
        if best > radius_m + radius_per_m * x:
            labels[i] = -1
    return x_out, res_out, labels


@_jit
def line_sums(x: Any, res: Any, labels: Any, offsets: Any, near_m: float) -> tuple[Any, Any]:
    """Return per line the weighted sums of ``x^j`` (j < 5) and ``x^j (res - offset)`` (j < 3).

    Weights ``1 / max(x, near_m)^2`` (image-space error); also ``[count, min x, max x]`` per
    line in the second array's columns 3-5.
    """
    n_lines = offsets.size
    sx = np.zeros((n_lines, 5))
    sy = np.zeros((n_lines, 6))
    for n in range(n_lines):
        sy[n, 4] = np.inf
        sy[n, 5] = -np.inf
    for i in range(x.size):
        n = labels[i]
        if n < 0:
            continue
        xi = x[i]
        w = 1.0 / max(xi, near_m)
        w *= w
        d = res[i] - offsets[n]
        p = w
        for j in range(5):
            sx[n, j] += p
            if j < 3:
                sy[n, j] += p * d
            p *= xi
        sy[n, 3] += 1.0
        sy[n, 4] = min(sy[n, 4], xi)
        sy[n, 5] = max(sy[n, 5], xi)
    return sx, sy


@_jit
def reassign(x: Any, res: Any, lines: Any, radius_m: float, radius_per_m: float) -> Any:
    """Assign each point to the nearest corrected line ``(offset, c0, c1, c2)`` within radius."""
    n = x.size
    labels = np.empty(n, dtype=np.intp)
    for i in range(n):
        labels[i] = -1
        xi = x[i]
        if not math.isfinite(xi):
            continue
        best = np.inf
        for j in range(lines.shape[0]):
            d = abs(res[i] - lines[j, 0] - (lines[j, 1] + xi * (lines[j, 2] + xi * lines[j, 3])))
            if d < best:
                best = d
                labels[i] = j
        if best > radius_m + radius_per_m * xi:
            labels[i] = -1
    return labels


@_jit
def row_coverage(rows_px: Any, labels: Any, n_lines: int) -> Any:
    """Return per line ``[distinct image rows, first row, last row]`` of its points (pixels).

    Whole numbers in a float array: float allocations only, which the other kernels compile
    anyway (each distinct allocator costs a fraction of a second on the first run).
    """
    out = np.zeros((n_lines, 3))
    if rows_px.size == 0 or n_lines == 0:
        return out
    low = high = rows_px[0]  # finite pixel rows; a loop, not .min()/.max() (compile time)
    for i in range(1, rows_px.size):
        low = min(low, rows_px[i])
        high = max(high, rows_px[i])
    lo = int(np.rint(low))
    hi = int(np.rint(high))
    span = hi - lo + 1
    seen = np.zeros(n_lines * span)
    for n in range(n_lines):
        out[n, 1] = hi + 1
        out[n, 2] = lo - 1
    for i in range(rows_px.size):
        n = labels[i]
        if n < 0:
            continue
        row = int(np.rint(rows_px[i]))
        if seen[n * span + row - lo] == 0.0:
            seen[n * span + row - lo] = 1.0
            out[n, 0] += 1
            out[n, 1] = min(out[n, 1], row)
            out[n, 2] = max(out[n, 2], row)
    return out


def signatures() -> dict[Any, tuple[Any, ...]]:
    """Each public kernel of this module with the argument types the fit passes it."""
    from numba import types

    f8, i8 = types.float64, types.int64
    a, a2, ia = types.float64[::1], types.float64[:, ::1], types.intp[::1]
    return {
        ray_slopes: (a, a, a2, f8, f8, f8, f8),
        total_cost: (a, a, a, a, a, a, a),
        batch_cost: (a, a, a, a, a2, a, a),
        nelder_mead: (a2, a, ia, a, a, a, f8, f8, i8, a, a, a, a, a, a),
        assign_points: (a, a, f8, f8, f8, f8, f8, f8, a, f8, f8),
        line_sums: (a, a, ia, a, f8),
        reassign: (a, a, a2, f8, f8),
        row_coverage: (a, ia, i8),
    }
