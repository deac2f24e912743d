"""Tests of the SUPER-to-vehicle curvature alignment (look-ahead, smoothing, lateral term)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from superlane_tools.lanes.lookahead import (
    align_super_curvature,
    lateral_in_lane,
)

LANE_WIDTH_M = 3.5


def _drive(k0: float, dk: float, amp: float, lookahead: float) -> dict[str, np.ndarray]:
    """A clothoid road, a slow weave in the lane, and what a perfect SUPER fit would see."""
    s = np.arange(0.0, 600.0, 1.8)  # 27 m/s at 15 Hz

    def road(x: np.ndarray) -> np.ndarray:
        return k0 + dk * np.sin(2 * np.pi * x / 400.0)

    lateral = amp * np.sin(2 * np.pi * s / 250.0)
    lateral_dd = -amp * (2 * np.pi / 250.0) ** 2 * np.sin(2 * np.pi * s / 250.0)
    return {
        "s": s,
        "fit": road(s + lookahead),
        "centre": -lateral,
        "truth": road(s) + lateral_dd,
        "road": road(s),
    }


@settings(max_examples=25, deadline=None)
@given(
    k0=st.floats(-3e-3, 3e-3),
    dk=st.floats(0.0, 4e-3),
    amp=st.floats(0.0, 1.2),
    lookahead=st.floats(10.0, 40.0),
)
def test_recovers_path_curvature_at_the_vehicle(
    k0: float, dk: float, amp: float, lookahead: float
) -> None:
    d = _drive(k0, dk, amp, lookahead)
    n = d["s"].size
    out = align_super_curvature(
        d["s"], d["fit"], np.full(n, lookahead), d["centre"], np.full(n, LANE_WIDTH_M)
    )
    ok = np.isfinite(out.path_per_m)
    assert ok.sum() > 0.7 * n
    # Raw 2*a2 compared at the frame is off by the look-ahead and the weave; aligned is not.
    assert np.sqrt(np.mean((out.path_per_m[ok] - d["truth"][ok]) ** 2)) < 2e-5 + 0.02 * dk
    assert np.allclose(out.road_per_m[ok], d["road"][ok], atol=1e-5 + 0.02 * dk)


def test_lane_change_is_unwrapped() -> None:
    # Vehicle moves 3.5 m left over 100 frames; the ego lane switches half-way.
    true_lateral = np.linspace(-1.75 + 0.1, 1.75 + 0.1, 101)
    centre = -true_lateral.copy()
    centre[51:] -= LANE_WIDTH_M  # new ego lane: its centre is one width further left
    centre[[20, 70]] = np.nan
    out = lateral_in_lane(centre, np.full(101, LANE_WIDTH_M))
    ok = np.isfinite(centre)
    assert np.allclose(out[ok], true_lateral[ok])
    assert np.isnan(out[20])


def test_gaps_and_missing_truth_stay_nan() -> None:
    d = _drive(1e-3, 0.0, 0.0, 20.0)
    n = d["s"].size
    fit = d["fit"].copy()
    fit[100:130] = np.nan
    s = d["s"].copy()
    s[:10] = np.nan
    out = align_super_curvature(s, fit, np.full(n, 20.0), d["centre"], np.full(n, 3.5))
    assert np.isnan(out.path_per_m[:10]).all()
    assert np.isfinite(out.path_per_m[50:80]).all()
    assert out.road_per_m[50:80] == pytest.approx(1e-3, abs=1e-9)
