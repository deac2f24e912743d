"""The effective look-ahead of a quadratic fit: where its 2*a2 equals a clothoid's curvature."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from superlane_tools.lanes import effective_lookahead
from superlane_tools.lanes.fit_lookahead import refit_sqrt_weights


def test_uniform_unweighted_points_give_the_midpoint() -> None:
    x = np.linspace(0.0, 60.0, 601)
    assert abs(effective_lookahead(x, np.zeros(x.size, np.intp)) - 30.0) < 1e-6


@settings(max_examples=30, deadline=None)
@given(
    k0=st.floats(-5e-3, 5e-3),
    kp=st.floats(-5e-5, 5e-5),
    near=st.floats(3.0, 10.0),
    far=st.floats(30.0, 70.0),
    offsets=st.lists(st.floats(-6.0, 6.0), min_size=1, max_size=4, unique=True),
    seed=st.integers(0, 2**31),
)
def test_clothoid_curvature_at_the_effective_lookahead(k0, kp, near, far, offsets, seed):
    rng = np.random.default_rng(seed)
    # Pixels are dense near the camera: forward distance ~ 1/row, rows uniform.
    rows = rng.uniform(1.0 / far, 1.0 / near, size=(len(offsets), 300))
    x = (1.0 / rows).ravel()
    labels = np.repeat(np.arange(len(offsets)), 300)
    y = np.asarray(offsets)[labels] + 0.01 * x + k0 / 2 * x**2 + kp / 6 * x**3
    w = refit_sqrt_weights(x)
    onehot = np.eye(len(offsets))[labels]
    design = np.hstack([onehot, x[:, None], (x * x)[:, None]]) * w[:, None]
    a2 = np.linalg.lstsq(design, y * w, rcond=None)[0][-1]
    ahead = effective_lookahead(x, labels, w)
    assert near <= ahead <= far
    assert abs(2 * a2 - (k0 + kp * ahead)) < 1e-9 + 1e-6 * abs(kp) * far
    # The midpoint of the supported range is farther than where the fit measures.
    assert ahead < 0.5 * (x.min() + x.max())
