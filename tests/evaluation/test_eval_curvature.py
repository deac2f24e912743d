"""Curvature error statistics."""

from __future__ import annotations

import math

import numpy as np

from superlane_tools.evaluation.curvature import curvature_errors


def test_known_errors():
    truth = np.array([0.0, 0.001, 0.002, np.nan, 0.003])
    est = np.array([0.0005, 0.0015, np.nan, 0.1, 0.0035])
    res = curvature_errors(est, truth)
    assert res.n == 3
    assert math.isclose(res.coverage, 0.75)
    assert math.isclose(res.rmse, 0.0005)
    assert math.isclose(res.mae, 0.0005)
    assert math.isclose(res.bias, 0.0005)
    assert math.isclose(res.correlation, 1.0)


def test_no_overlap_gives_nan():
    res = curvature_errors(np.array([np.nan, np.nan]), np.array([0.1, 0.2]))
    assert res.n == 0
    assert res.coverage == 0.0
    assert math.isnan(res.rmse)
