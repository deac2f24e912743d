"""RTK curvature ground truth: known circles and clothoids in, their curvature out."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from superlane_tools.geo.curvature import CurvatureParams, trajectory_curvature


def _circle(radius_m: float, speed_mps: float, rate_hz: float, duration_s: float, left: bool):
    t = np.arange(0.0, duration_s, 1.0 / rate_hz)
    ang = speed_mps * t / radius_m * (1 if left else -1)
    east = radius_m * np.sin(np.abs(ang))
    north = (radius_m - radius_m * np.cos(ang)) * (1 if left else -1)
    return (t * 1e9).astype(np.int64), east, north


@settings(max_examples=25, deadline=None)
@given(
    radius=st.floats(150.0, 3000.0),
    speed=st.floats(8.0, 35.0),
    left=st.booleans(),
    seed=st.integers(0, 2**32 - 1),
)
def test_circle_curvature_with_centimetre_noise(radius, speed, left, seed):
    t, e, n = _circle(radius, speed, 10.0, 40.0, left)
    rng = np.random.default_rng(seed)
    e = e + rng.normal(0, 0.02, e.shape)
    n = n + rng.normal(0, 0.02, n.shape)
    res = trajectory_curvature(t, e, n, np.ones(t.shape, bool), t)
    k = res.curvature_per_m[res.valid]
    assert k.size > 0.3 * t.size
    expected = (1 if left else -1) / radius
    assert np.sqrt(np.mean((k - expected) ** 2)) < 2.5e-4


def test_straight_line_heading_and_zero_curvature():
    t = (np.arange(0, 30, 0.1) * 1e9).astype(np.int64)
    s = 20.0 * np.arange(0, 30, 0.1)
    e, n = s * np.cos(0.7), s * np.sin(0.7)
    res = trajectory_curvature(t, e, n, np.ones(t.shape, bool), t)
    assert np.allclose(res.heading_rad[res.valid], 0.7, atol=1e-6)
    assert np.allclose(res.curvature_per_m[res.valid], 0.0, atol=1e-6)


def test_degraded_fixes_and_dropouts_are_not_used():
    t, e, n = _circle(300.0, 20.0, 10.0, 60.0, True)
    good = np.ones(t.shape, bool)
    good[200:230] = False  # float fixes
    e_bad = e.copy()
    e_bad[200:230] += 3.0  # metre noise on degraded fixes must not leak in
    query = t
    res = trajectory_curvature(t, e_bad, n, good, query)
    assert not res.valid[200:230].any()
    assert np.isnan(res.curvature_per_m[200:230]).all()
    ok = res.valid
    assert np.max(np.abs(res.curvature_per_m[ok] - 1 / 300.0)) < 2e-4


def test_query_outside_the_trajectory_is_nan():
    t, e, n = _circle(500.0, 20.0, 10.0, 20.0, True)
    q = np.array([t[0] - 10**9, t[-1] + 10**9], dtype=np.int64)
    res = trajectory_curvature(t, e, n, np.ones(t.shape, bool), q, CurvatureParams())
    assert np.isnan(res.curvature_per_m).all()
    assert not res.valid.any()


@pytest.mark.parametrize("window_m", [20.0, 40.0])
def test_clothoid_curvature_tracks_linear_change(window_m):
    ds = 0.05
    s = np.arange(0, 600, ds)
    k_true = np.clip((s - 100) / 400 * (1 / 200), 0, 1 / 200)
    heading = np.cumsum(k_true) * ds
    e = np.cumsum(np.cos(heading)) * ds
    n = np.cumsum(np.sin(heading)) * ds
    t_s = s / 25.0
    pick = slice(None, None, 25)  # 20 Hz at 25 m/s -> 1.25 m spacing
    t = (t_s[pick] * 1e9).astype(np.int64)
    res = trajectory_curvature(
        t, e[pick], n[pick], np.ones(t.shape, bool), t, CurvatureParams(window_m=window_m)
    )
    k_ref = k_true[pick]
    err = res.curvature_per_m[res.valid] - k_ref[res.valid]
    assert np.sqrt(np.mean(err**2)) < 1e-4
