"""The evidence rule: a histogram peak of a few stray pixels gives no lane line."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from superlane_tools.lanes import FitParams, fit_frame

from .conftest import make_camera, render_lanes


@pytest.mark.parametrize("backend", ["numba", "numpy"])
def test_a_peak_of_a_few_pixels_is_not_fitted(backend: str) -> None:
    camera = make_camera()
    lane, road = render_lanes(camera, [1.85, -1.85, -5.55], 0.0, 0.0, 0.0)
    # A phantom line on the shoulder, 5.5 m left of the left line: 12 pixels between 8 and 14 m.
    x = np.linspace(8.0, 14.0, 12)
    phantom, front = camera.project(np.stack([x, np.full(12, 7.4), np.zeros(12)], axis=1))
    pixels = np.concatenate([lane, np.round(phantom[front])])
    # Without the rule, with a low peak threshold (every pixel used, any peak of 3 points), the
    # 12 pixels give a line of their own.
    loose = replace(
        FitParams(),
        backend=backend,
        min_prominence_points=3,
        min_prominence_fraction=0.0,
        max_points=20_000,
        min_line_points=0,
    )
    off = fit_frame(pixels, road, camera, loose)
    assert any(abs(ln.offset_m - 7.4) < 0.5 for ln in off.lanes), off.lanes
    on = fit_frame(pixels, road, camera, replace(loose, min_line_points=20))
    assert not any(abs(ln.offset_m - 7.4) < 0.5 for ln in on.lanes)
    assert len(on.lanes) == len(off.lanes) - 1
    assert min(ln.n_points for ln in on.lanes) >= 20
    # The ego pair is the same lines either way.
    ego = (off.lanes[off.ego_left].offset_m, off.lanes[off.ego_right].offset_m)
    assert (on.lanes[on.ego_left].offset_m, on.lanes[on.ego_right].offset_m) == pytest.approx(ego)
    assert FitParams().min_line_points == 20  # the default reprocess uses


def test_negative_minimum_is_refused() -> None:
    from superlane_tools.lanes.errors import FitParamsError

    with pytest.raises(FitParamsError, match="min_line_points"):
        FitParams(min_line_points=-1)
