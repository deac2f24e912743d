"""Property tests: random parallel-lane scenes rendered to masks are recovered by the fit.

Stated tolerances (with the default ``FitParams``, lines 4-60 m ahead, 1280x720 pinhole):
heading 0.005 rad, curvature 5e-4 1/m, slope 0.004 (rise over run), offsets 0.15 m.
"""

from __future__ import annotations

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from superlane_tools.lanes import fit_frame

HEADING_TOL_RAD = 0.005
CURVATURE_TOL = 5e-4
SLOPE_TOL = 0.004
OFFSET_TOL_M = 0.15


@st.composite
def scenes(draw: st.DrawFn) -> dict[str, object]:
    n = draw(st.integers(2, 5))
    width = draw(st.floats(2.8, 3.9))
    first = -draw(st.floats(0.3, width - 0.3)) - width * (n // 2 - 1)
    return {
        "offsets": [first + width * k for k in range(n)],
        "a1": draw(st.floats(-0.05, 0.05)),
        "curvature": draw(st.floats(-1 / 150, 1 / 150)),
        "slope": draw(st.floats(-0.04, 0.04)),
        "height": draw(st.floats(1.2, 2.0)),
        "pitch": draw(st.floats(0.02, 0.1)),
        "focal": draw(st.floats(800.0, 1400.0)),
    }


@settings(
    max_examples=20,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
)
@given(scene=scenes())
def test_fit_recovers_random_scene(scene: dict, renderer, camera_factory) -> None:
    camera = camera_factory(scene["height"], scene["pitch"], scene["focal"])
    offsets = np.asarray(scene["offsets"])
    lane_uv, road_uv = renderer(
        camera, offsets, scene["a1"], scene["curvature"] / 2, scene["slope"]
    )
    fit = fit_frame(lane_uv, road_uv, camera)
    assert fit.reason == ""
    assert len(fit.lanes) == offsets.size
    assert abs(fit.a1 - scene["a1"]) < HEADING_TOL_RAD
    assert abs(fit.curvature - scene["curvature"]) < CURVATURE_TOL
    assert abs(fit.b - scene["slope"]) < SLOPE_TOL
    np.testing.assert_allclose(np.sort(fit.offsets), np.sort(offsets), atol=OFFSET_TOL_M)
    assert fit.lane_width_m > 2.4
