"""Time alignment (Hypothesis properties) and WGS84 -> ENU / speed / heading."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from superlane_tools.errors import UsageError
from superlane_tools.geo import GeoError, geodetic_to_enu, parse_origin, speed_heading
from superlane_tools.recording.align import align

times = arrays(np.int64, st.integers(1, 40), elements=st.integers(0, 10_000), unique=True)


@given(times, st.sampled_from(["nearest", "previous", "linear"]))
def test_align_at_stream_times_returns_values(t: np.ndarray, method: str) -> None:
    values = np.arange(len(t), dtype=np.float64) * 1.5
    out = align(t, values, t, method=method)  # type: ignore[arg-type]
    np.testing.assert_array_equal(out, values)


@given(times, arrays(np.int64, st.integers(1, 30), elements=st.integers(-500, 10_500)))
def test_align_properties(t: np.ndarray, target: np.ndarray) -> None:
    values = 3.0 * t.astype(np.float64) - 7.0  # a linear signal of time
    inside = (target >= t.min()) & (target <= t.max())
    lin = align(t, values, target, method="linear")
    np.testing.assert_allclose(lin[inside], 3.0 * target[inside] - 7.0, rtol=1e-9)
    assert np.isnan(lin[~inside]).all()
    prev = align(t, values, target, method="previous")
    assert np.all((prev[inside] + 7.0) / 3.0 <= target[inside])
    near = align(t, values, target, method="nearest")
    dist = np.abs((near[inside] + 7.0) / 3.0 - target[inside])
    best = np.min(np.abs(t[None, :] - target[inside][:, None]), axis=1)
    np.testing.assert_allclose(dist, best)
    tight = align(t, values, target, method="nearest", tolerance_ns=0)
    assert np.array_equal(~np.isnan(tight), np.isin(target, t))


@settings(max_examples=30)
@given(times, st.integers(0, 10_000))
def test_align_previous_tolerance(t: np.ndarray, tol: int) -> None:
    target = np.arange(0, 10_001, 37)
    out = align(t, t.astype(np.float64), target, method="previous", tolerance_ns=tol)
    ok = ~np.isnan(out)
    assert np.all(target[ok] - out[ok] <= tol)


def test_align_linear_does_not_bridge_dropouts_and_keeps_shape() -> None:
    t = np.array([0, 10, 100])
    v = np.array([[0.0, 1.0], [10.0, 2.0], [100.0, 3.0]])
    out = align(t, v, [5, 50], method="linear", tolerance_ns=20)
    np.testing.assert_allclose(out[0], [5.0, 1.5])
    assert np.isnan(out[1]).all()
    with pytest.raises(UsageError):
        align(t, v, [1], method="cubic")  # type: ignore[arg-type]


def test_enu_and_kinematics_of_a_straight_drive() -> None:
    # 10 m/s due north-east for 20 s at 10 Hz, with a duplicate stamp and a dropout
    t = np.arange(200, dtype=np.int64) * 100_000_000
    dist = 10.0 * t * 1e-9
    east, north = dist / np.sqrt(2), dist / np.sqrt(2)
    import pymap3d

    lat, lon, alt = pymap3d.enu2geodetic(east, north, np.zeros_like(east), 48.0, 11.0, 500.0)
    keep = np.ones(200, dtype=bool)
    keep[100:120] = False  # 2 s dropout
    t, lat, lon, alt = t[keep], lat[keep], lon[keep], alt[keep]
    t = np.insert(t, 5, t[5])
    lat, lon, alt = np.insert(lat, 5, lat[5]), np.insert(lon, 5, lon[5]), np.insert(alt, 5, alt[5])
    enu = geodetic_to_enu(lat, lon, alt)
    assert enu.origin.latitude_deg == pytest.approx(48.0)
    kin = speed_heading(t, enu.east_m, enu.north_m)
    np.testing.assert_allclose(kin.speed_mps, 10.0, rtol=1e-4)
    np.testing.assert_allclose(kin.heading_rad, np.pi / 4, atol=1e-4)


def test_enu_invalid_fixes_and_origin_parsing() -> None:
    enu = geodetic_to_enu([0.0, 48.0, np.nan], [0.0, 11.0, 11.0], [0.0, 500.0, 500.0])
    assert np.isnan(enu.east_m[0])
    assert enu.east_m[1] == 0.0
    assert np.isnan(enu.east_m[2])
    with pytest.raises(GeoError):
        geodetic_to_enu([np.nan], [0.0], [0.0])
    assert parse_origin("48.1, 11.5") == (48.1, 11.5, 0.0)
    with pytest.raises(GeoError):
        parse_origin("north,east")
