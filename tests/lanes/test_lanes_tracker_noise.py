"""The lane tracker with each frame's fit covariance (correlated ``2*a2`` / ``b`` errors)."""

from __future__ import annotations

import numpy as np
import pytest

from superlane_tools.drive.config import TrackingConfig
from superlane_tools.errors import ConfigError
from superlane_tools.lanes.tracker import (
    TrackerParams,
    cov_from_columns,
    fit_noise,
    track_lanes,
)


def _drive(seed: int) -> tuple[dict[str, np.ndarray], np.ndarray, np.ndarray]:
    """Return tracker inputs of a 600 m drive whose ``2*a2`` and ``b`` errors correlate (0.9).

    The covariance of ``(a1, a2, b)`` is returned per frame (its scale varying as a fit's
    support does), with the measurement errors drawn from it; and the true road curvature.
    """
    rng = np.random.default_rng(seed)
    s = np.arange(0.0, 600.0, 2.0)
    n = s.size
    k_true = np.where(s < 200, 0.0, np.where(s < 400, 2e-3 * (s - 200) / 200, 2e-3))
    scale = rng.uniform(0.5, 2.0, n)
    sd = np.array([3e-3, 5e-4 / 2, 3e-3])  # a1 (rad), a2 (1/m), b
    corr = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.9], [0.0, 0.9, 1.0]])
    cov = corr * np.outer(sd, sd) * (scale**2)[:, None, None]
    err = np.einsum("kij,kj->ki", np.linalg.cholesky(cov), rng.standard_normal((n, 3)))
    inputs = {
        "s_m": s,
        "heading_rad": -(0.0 + err[:, 0]),
        "curvature_per_m": k_true + 2.0 * err[:, 1],
        "slope": 0.006 + err[:, 2],
        "near_m": np.zeros(n),  # a (very short) view at the vehicle: 2*a2 is k there
        "far_m": np.full(n, 2e-3),
        "valid": np.ones(n, dtype=bool),
    }
    return inputs, cov, k_true


def _rmse(
    params: TrackerParams, inputs: dict[str, np.ndarray], cov: np.ndarray, k: np.ndarray
) -> float:
    track = track_lanes(**inputs, params=params, fit_cov=cov)  # type: ignore[arg-type]
    return float(np.sqrt(np.mean((track.road_per_m - k)[20:] ** 2)))


def test_full_fit_covariance_beats_its_diagonal_on_correlated_errors() -> None:
    params = TrackerParams(measurement_noise="fit", fit_noise_inflation=1.0, fit_noise_floor=0.0)
    wins = 0
    for seed in range(5):
        inputs, cov, k = _drive(seed)
        diagonal = cov * np.eye(3)[None]
        full = _rmse(params, inputs, cov, k)
        diag = _rmse(params, inputs, diagonal, k)
        wins += full < diag
        assert full < 1.2 * diag
    assert wins >= 4


def test_fit_mode_without_covariances_is_the_fixed_tracker() -> None:
    inputs, cov, k = _drive(0)
    fixed = track_lanes(**inputs, params=TrackerParams(measurement_noise="fixed"))  # type: ignore[arg-type]
    nan_cov = np.full_like(cov, np.nan)
    fit = track_lanes(  # type: ignore[arg-type]
        **inputs, params=TrackerParams(measurement_noise="fit"), fit_cov=nan_cov
    )
    np.testing.assert_array_equal(fixed.road_per_m, fit.road_per_m)
    assert np.sqrt(np.mean((fixed.road_per_m - k)[20:] ** 2)) < 5e-4


def test_fit_noise_inflates_floors_and_keeps_the_correlation() -> None:
    fixed = np.array([5e-3, 5e-4, 3e-3])
    cov = np.diag([1e-6, 1e-10, 1e-4])
    cov[1, 2] = cov[2, 1] = 0.5 * 1e-5 * 1e-2
    r = fit_noise(cov, fixed, TrackerParams(fit_noise_inflation=4.0, fit_noise_floor=0.3))
    sd = np.sqrt(np.diag(r))
    # a1: 1e-3 * 2 = 2e-3 > floor 1.5e-3; 2*a2: 2e-5 * 2 < floor 1.5e-4; b: 1e-2 * 2.
    np.testing.assert_allclose(sd, [2e-3, 1.5e-4, 2e-2])
    assert r[1, 2] / (sd[1] * sd[2]) == pytest.approx(0.5)
    assert r[0, 1] == 0.0
    bad = fit_noise(np.full((3, 3), np.nan), fixed, TrackerParams())
    np.testing.assert_array_equal(bad, np.diag(fixed**2))


def test_cov_columns_round_trip_and_config_validation() -> None:
    full = np.array([[1.0, 2.0, 3.0], [2.0, 4.0, 5.0], [3.0, 5.0, 6.0]])
    cols = [np.array([full[i, j]]) for i, j in ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))]
    np.testing.assert_array_equal(cov_from_columns(cols)[0], full)
    with pytest.raises(ConfigError):
        TrackingConfig(measurement_noise="diagonal")
    with pytest.raises(ConfigError):
        TrackingConfig(fit_noise_inflation=0.0)
