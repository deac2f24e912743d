"""The refit's covariance of the shared ``(a1, a2, b)`` against the scatter of noisy fits."""

from __future__ import annotations

import numpy as np
import pytest

from superlane_tools.lanes import FitParams, fit_frame
from superlane_tools.lanes._refit import SharedModel, refit_shared

HEIGHT_M = 1.5
OFFSETS = np.array([-5.4, -1.8, 1.8, 5.4])


def _rays(
    rng: np.random.Generator, a1: float, a2: float, b: float, noise: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return ``iq, r, labels`` of four lines on the road of slope ``b``, ``r`` noisy (rad)."""
    x = rng.uniform(5.0, 60.0, (OFFSETS.size, 250))
    labels = np.repeat(np.arange(OFFSETS.size), x.shape[1])
    x = x.ravel()
    y = OFFSETS[labels] + a1 * x + a2 * x * x
    iq = 1.0 / x - b / HEIGHT_M
    r = y / x + noise * rng.standard_normal(x.size)
    return iq, r, labels


@pytest.mark.parametrize("compiled", [False, True])
def test_covariance_matches_the_scatter_of_noisy_fits(compiled: bool) -> None:
    rng = np.random.default_rng(7)
    start = SharedModel(0.0, 0.0, 0.0, OFFSETS.copy())
    estimates, covs = [], []
    for _ in range(200):
        iq, r, labels = _rays(rng, 0.01, 1.0 / 1600, 0.006, 2e-3)
        model = refit_shared(
            iq, r, labels, 4, start, HEIGHT_M, 2, True, 0.04, 200.0, compiled=compiled
        )
        assert model.cov is not None
        estimates.append([model.a1, model.a2, model.b])
        covs.append(model.cov)
    empirical = np.cov(np.array(estimates).T)
    predicted = np.mean(covs, axis=0)
    ratio = np.sqrt(np.diag(predicted) / np.diag(empirical))
    assert np.all((ratio > 0.75) & (ratio < 1.33)), ratio
    # Tenfold noise: tenfold standard deviations (the residual variance is estimated).
    iq, r, labels = _rays(rng, 0.01, 1.0 / 1600, 0.006, 2e-2)
    loud = refit_shared(iq, r, labels, 4, start, HEIGHT_M, 2, True, 0.04, 200.0, compiled=compiled)
    assert loud.cov is not None
    assert np.sqrt(loud.cov[1, 1] / predicted[1, 1]) == pytest.approx(10.0, rel=0.3)


def test_covariance_rows_of_parameters_not_fitted_are_nan() -> None:
    rng = np.random.default_rng(1)
    iq, r, labels = _rays(rng, 0.0, 0.0, 0.0, 1e-3)
    start = SharedModel(0.0, 0.0, 0.0, OFFSETS.copy())
    model = refit_shared(iq, r, labels, 4, start, HEIGHT_M, 2, False, 0.04, 200.0)
    assert model.cov is not None
    assert np.isfinite(model.cov[:2, :2]).all()
    assert np.isnan(model.cov[2]).all()
    assert np.isnan(model.cov[:, 2]).all()


def test_fit_frame_reports_a_covariance(renderer, camera_factory) -> None:
    camera = camera_factory()
    lane, road = renderer(camera, (-5.4, -1.8, 1.8, 5.4), 0.01, 1.0 / 1200, 0.01)
    fit = fit_frame(lane, road, camera, FitParams())
    assert fit.ok
    assert fit.shared_cov.shape == (3, 3)
    assert np.isfinite(fit.shared_cov).all()
    assert np.allclose(fit.shared_cov, fit.shared_cov.T)
    assert np.all(np.linalg.eigvalsh(fit.shared_cov) > 0)
    # Pure noise-free pixels: the heading is known to far better than a degree.
    assert np.sqrt(fit.shared_cov[0, 0]) < 0.01
