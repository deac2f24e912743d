"""Curvature error statistics against RTK ground truth (SUPER paper IV-E, Fig. 11)."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]


class CurvatureErrors(NamedTuple):
    """Errors of an estimated curvature profile against ground truth (all in 1/m).

    Attributes:
        n: Number of frames where both values are finite.
        coverage: ``n`` divided by the number of frames with ground truth.
        rmse: Root-mean-square error.
        mae: Mean absolute error.
        bias: Mean signed error (estimate minus truth).
        correlation: Pearson correlation coefficient (NaN with fewer than 3 pairs or no spread).
    """

    n: int
    coverage: float
    rmse: float
    mae: float
    bias: float
    correlation: float


def curvature_errors(estimate: FloatArray, truth: FloatArray) -> CurvatureErrors:
    """Compare an estimated curvature profile (1/m) with ground truth at the same frames.

    NaN in either input marks a frame without a value; such frames are left out.
    """
    est = np.asarray(estimate, dtype=np.float64)
    ref = np.asarray(truth, dtype=np.float64)
    has_truth = np.isfinite(ref)
    both = has_truth & np.isfinite(est)
    n = int(both.sum())
    coverage = n / int(has_truth.sum()) if has_truth.any() else 0.0
    if n == 0:
        nan = float("nan")
        return CurvatureErrors(0, coverage, nan, nan, nan, nan)
    err = est[both] - ref[both]
    corr = float("nan")
    if n >= 3 and np.std(est[both]) > 0 and np.std(ref[both]) > 0:
        corr = float(np.corrcoef(est[both], ref[both])[0, 1])
    return CurvatureErrors(
        n=n,
        coverage=coverage,
        rmse=float(np.sqrt(np.mean(err * err))),
        mae=float(np.mean(np.abs(err))),
        bias=float(np.mean(err)),
        correlation=corr,
    )
