"""Tests of the lane tracker (Kalman filter + RTS smoother over travelled distance)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from superlane_tools.drive.config import TrackingConfig, config_from_mapping
from superlane_tools.errors import ConfigError
from superlane_tools.lanes.tracker import (
    TrackerParams,
    measurement_matrix,
    track_lanes,
    travelled_m,
)


def _ls_quadratic(x: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    """Return ``(a1, 2*a2)`` of a least-squares quadratic ``y = a0 + a1 x + a2 x^2``."""
    a2, a1, _a0 = np.polyfit(x, y, 2)
    return float(a1), float(2 * a2)


@settings(max_examples=40, deadline=None)
@given(
    psi=st.floats(-0.03, 0.03),
    k=st.floats(-4e-3, 4e-3),
    k1=st.floats(-1e-4, 1e-4),
    near=st.floats(3.0, 15.0),
    length=st.floats(10.0, 50.0),
)
def test_measurement_matrix_is_the_quadratic_fit_of_a_clothoid(
    psi: float, k: float, k1: float, near: float, length: float
) -> None:
    # A clothoid lane seen from a vehicle heading psi relative to it, fitted over [near, far].
    x = np.linspace(near, near + length, 400)
    y = 0.7 - psi * x + k * x**2 / 2 + k1 * x**3 / 6
    a1, curvature = _ls_quadratic(x, y)
    h = measurement_matrix(near + 0.5 * length, 0.5 * length)
    predicted = h @ np.array([psi, 0.0, k, k1, 0.01])
    assert predicted[0] == pytest.approx(-a1, abs=2e-6 + 1e-3 * abs(k1) * length**2)
    assert predicted[1] == pytest.approx(curvature, abs=1e-7)
    assert predicted[2] == pytest.approx(0.01)


def test_travelled_distance_integrates_speed() -> None:
    t_ns = (np.arange(31) * (1e9 / 15)).astype(np.int64)
    speed = np.full(31, 20.0)
    speed[5] = np.nan  # a missing sample is bridged
    s = travelled_m(t_ns, speed)
    assert np.allclose(s, 20.0 * np.arange(31) / 15)
    assert np.isnan(travelled_m(t_ns, np.full(31, np.nan))).all()


def _simulated_fits(seed: int) -> dict[str, np.ndarray]:
    """A clothoid road with a lane change, as per-frame quadratic fits with noise and failures."""
    rng = np.random.default_rng(seed)
    n, step = 450, 1.8  # 30 s at 27 m/s, 15 Hz
    s = np.arange(n) * step

    def road(x: np.ndarray) -> np.ndarray:  # straight, clothoid in, arc, clothoid out
        return np.interp(x, [0, 150, 250, 450, 550, 2000], [0, 0, 3e-3, 3e-3, 0, 0])

    # Lane change to the left, 3.5 m over 90 m, centred at s = 400 m.
    u = np.clip((s - 355.0) / 90.0, 0.0, 1.0)
    lateral = 3.5 * (u - np.sin(2 * np.pi * u) / (2 * np.pi))
    psi = np.gradient(lateral, s)
    manoeuvre = np.gradient(psi, s)
    a1 = np.empty(n)
    curv = np.empty(n)
    near = rng.uniform(4.0, 10.0, n)
    far = rng.uniform(22.0, 40.0, n)
    for i in range(n):
        x = np.linspace(0.0, far[i], 400)
        dx = np.diff(x)
        k_ahead = road(s[i] + x)
        heading = np.concatenate([[0.0], np.cumsum(0.5 * (k_ahead[1:] + k_ahead[:-1]) * dx)])
        bend = np.concatenate([[0.0], np.cumsum(0.5 * (heading[1:] + heading[:-1]) * dx)])
        y = -lateral[i] - psi[i] * x + bend
        seen = x >= near[i]
        a1[i], curv[i] = _ls_quadratic(x[seen], y[seen])
    a1 += rng.normal(0, 3e-3, n)
    curv += rng.normal(0, 4e-4, n)
    slope = 0.01 * np.sin(2 * np.pi * s / 600.0) + rng.normal(0, 1.5e-3, n)
    valid = np.ones(n, dtype=bool)
    bad = rng.choice(n, 40, replace=False)
    curv[bad[:20]] += rng.choice([-1, 1], 20) * rng.uniform(4e-3, 8e-3, 20)  # wrong but "valid"
    a1[bad[:20]] += rng.normal(0, 0.03, 20)
    slope[bad[:10]] += 0.02  # half of the wrong fits also bend the view
    valid[bad[20:]] = False  # collapsed fits flagged by the pipeline
    curv[bad[20:]] = 9e-3
    return {
        "s": s,
        "a1": a1,
        "curv": curv,
        "slope": slope,
        "near": near,
        "far": far,
        "valid": valid,
        "road": road(s),
        "path": road(s) + manoeuvre,
        "bad": bad[:20],
    }


@pytest.mark.parametrize("seed", [1, 2])
def test_tracker_recovers_road_and_path_curvature(seed: int) -> None:
    d = _simulated_fits(seed)
    out = track_lanes(d["s"], d["a1"], d["curv"], d["slope"], d["near"], d["far"], d["valid"])
    inner = slice(20, -20)
    road_rmse = np.sqrt(np.mean((out.road_per_m[inner] - d["road"][inner]) ** 2))
    path_rmse = np.sqrt(np.mean((out.path_per_m[inner] - d["path"][inner]) ** 2))
    raw_rmse = np.sqrt(np.mean((d["curv"][inner] - d["path"][inner]) ** 2))
    assert road_rmse < 2.5e-4
    assert path_rmse < 3.5e-4
    assert path_rmse < 0.2 * raw_rmse
    # Invalid fits are never used; most of the wrong "valid" ones are gated out.
    assert not out.used[~d["valid"]].any()
    assert out.gated[d["bad"]].mean() > 0.6


def test_without_gating_and_smoothing_the_outliers_hurt() -> None:
    d = _simulated_fits(1)
    args = (d["s"], d["a1"], d["curv"], d["slope"], d["near"], d["far"])
    good = track_lanes(*args, d["valid"])
    naive = track_lanes(*args, np.ones_like(d["valid"]), TrackerParams(gate_chi2=1e9, smooth=False))
    inner = slice(20, -20)

    def rmse(v: np.ndarray) -> float:
        return float(np.sqrt(np.mean((v[inner] - d["path"][inner]) ** 2)))

    assert rmse(good.path_per_m) < 0.4 * rmse(naive.path_per_m)


def test_track_restarts_after_a_gap_and_is_nan_before_the_first_fit() -> None:
    d = _simulated_fits(3)
    s = d["s"].copy()
    s[200:] += 100.0  # a jump in travelled distance: no prediction across it
    valid = d["valid"].copy()
    valid[:10] = False
    out = track_lanes(s, d["a1"], d["curv"], d["slope"], d["near"], d["far"], valid)
    assert np.isnan(out.road_per_m[:10]).all()
    first_after = 200 + int(np.argmax(valid[200:]))
    assert out.used[first_after]
    assert np.isfinite(out.path_per_m[first_after:]).all()


def test_tracking_config_section() -> None:
    cfg = config_from_mapping({"tracking": {"enabled": False, "gate_chi2": 9.2}})
    assert not cfg.tracking.enabled
    assert cfg.tracking.gate_chi2 == pytest.approx(9.2)
    assert cfg.to_dict()["tracking"]["manoeuvre_psd"] == TrackingConfig().manoeuvre_psd
    with pytest.raises(ConfigError):
        config_from_mapping({"tracking": {"max_slope_fraction": 1.5}})
    with pytest.raises(ConfigError):
        config_from_mapping({"tracking": {"nope": 1}})
