"""The effective look-ahead of a quadratic lane fit: where its ``2*a2`` describes the road.

On a road whose curvature changes along the way (a clothoid, ``kappa(x) = kappa0 + kappa' x``)
the lines are cubics ``y = offset + a1 x + kappa0/2 x^2 + kappa'/6 x^3``. A least-squares
quadratic fitted to their points returns ``2*a2 = kappa0 + kappa' * x_eff``: the curvature at
``x_eff`` ahead. ``x_eff`` depends only on the design of the fit -- where its points lie and
how they are weighted -- not on the road: regress ``x^3`` on the fit's own design (one offset
per line, ``x``, ``x^2``) with its weights; the ``x^2`` coefficient ``gamma`` gives
``x_eff = gamma / 3``. For uniform unweighted points over ``[0, L]`` this is ``L/2`` (the
midpoint); the refit's ``1 / max(x, 5 m)`` weights pull it much nearer.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.intp]


def effective_lookahead(
    x_m: FloatArray, labels: IntArray, sqrt_weights: FloatArray | None = None
) -> float:
    """Return the distance ahead at which a quadratic fit's ``2*a2`` measures the curvature.

    Args:
        x_m: Forward distance of each point the fit used, metres (NaN: unused).
        labels: Line index of each point (-1: unassigned, unused).
        sqrt_weights: Square root of each point's least-squares weight (None: equal weights).

    Returns:
        The effective look-ahead, metres; NaN when the points cannot determine a quadratic.
    """
    x = np.asarray(x_m, dtype=np.float64)
    lab = np.asarray(labels)
    keep = (lab >= 0) & np.isfinite(x)
    if sqrt_weights is not None:
        w_all = np.asarray(sqrt_weights, dtype=np.float64)
        keep &= np.isfinite(w_all) & (w_all > 0)
    x, lab = x[keep], lab[keep]
    if x.size < 4:
        return math.nan
    lines, index = np.unique(lab, return_inverse=True)
    if x.size < lines.size + 3:
        return math.nan
    w = np.ones(x.size) if sqrt_weights is None else np.asarray(sqrt_weights, np.float64)[keep]
    onehot = np.zeros((x.size, lines.size))
    onehot[np.arange(x.size), index] = 1.0
    scale = max(float(np.max(np.abs(x))), 1.0)  # condition the columns
    u = x / scale
    design = np.hstack([onehot, u[:, None], (u * u)[:, None]]) * w[:, None]
    target = u**3 * w
    coef, _res, rank, _sv = np.linalg.lstsq(design, target, rcond=None)
    if rank < design.shape[1]:
        return math.nan
    return float(coef[-1] / 3.0 * scale)


def refit_sqrt_weights(x_m: FloatArray, near_m: float = 5.0) -> FloatArray:
    """Return the refit's per-point weight roots ``1 / max(x, near_m)`` (image-space error)."""
    return 1.0 / np.maximum(np.asarray(x_m, dtype=np.float64), near_m)
