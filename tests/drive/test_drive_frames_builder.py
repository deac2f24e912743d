"""The drive's typed record, built frame by frame: every value kept exactly, past many blocks."""

from __future__ import annotations

import math

import numpy as np

from superlane_tools.camera import CameraModel, load_camera
from superlane_tools.corridor import CorridorGeometry, HoughResult
from superlane_tools.drive import DriveFramesBuilder, Finished, Prepared
from superlane_tools.drive.record import BLOCK_ROWS
from superlane_tools.lanes import LaneFit
from superlane_tools.reporting.layout import STAGES


def _frame(k: int, rng: np.random.Generator, camera: CameraModel) -> Finished:
    """A finished frame without a fit; corridor, Hough and stage times drawn at random."""
    decoded = k % 3 != 0
    prep = Prepared(
        k,
        1_700_000_000_000_000_000 + 66_666_667 * k,  # int64 beyond float precision
        None,
        error="" if decoded else "bad jpeg",
        hough=HoughResult(
            None, None, float(rng.uniform(3, 4)), float(rng.uniform(10, 40)), True, ""
        )
        if k % 2
        else None,
        seconds={s: float(rng.uniform(0, 0.01)) for s in STAGES},
        cpu_seconds={s: float(rng.uniform(0, 0.01)) for s in STAGES},
    )
    lanes = CorridorGeometry(float(rng.uniform(3, 4)), float(rng.uniform(5, 60)), 0)
    net = CorridorGeometry(float(rng.uniform(3, 4)), math.nan, int(rng.integers(0, 90)))
    return Finished(prep, LaneFit(reason="no lane points"), lanes, net, None, camera)


def test_builder_keeps_every_frame_exactly_past_many_blocks() -> None:
    rng = np.random.default_rng(3)
    camera = load_camera("sim_default")
    done = [_frame(k, rng, camera) for k in range(3 * BLOCK_ROWS + 7)]
    builder = DriveFramesBuilder(max_slope=0.1)
    for frame in done:
        builder.add(frame)
    frames = builder.frames()
    assert len(frames) == len(done)
    assert frames.t_ns.dtype == np.int64
    assert frames.t_ns.tolist() == [d.prepared.log_time_ns for d in done]
    assert frames.decoded.tolist() == [not d.prepared.error for d in done]
    c = frames.corridors
    np.testing.assert_array_equal(c.super_width_m, [d.super_corridor.width_m for d in done])
    np.testing.assert_array_equal(c.super_length_m, [d.super_corridor.length_m for d in done])
    np.testing.assert_array_equal(c.net_width_m, [d.net_corridor.width_m for d in done])
    np.testing.assert_array_equal(c.net_length_m, [d.net_corridor.length_m for d in done])
    hough = [d.prepared.hough for d in done]
    np.testing.assert_array_equal(c.hough_width_m, [h.width_m if h else math.nan for h in hough])
    np.testing.assert_array_equal(c.hough_length_m, [h.range_m if h else math.nan for h in hough])
    assert np.isnan(frames.fit.curvature_per_m).all()  # no frame has a fit
    assert not frames.fit.trackable.any()
    assert frames.fit.cov.shape == (len(done), 3, 3)
    expected = [[d.prepared.seconds[s] for s in STAGES] for d in done]
    np.testing.assert_array_equal(frames.stage_s, expected)
    totals = frames.stage_totals()
    assert math.isclose(totals["decode"], sum(d.prepared.seconds["decode"] for d in done))
    # A record is a snapshot: frames added later do not change it.
    builder.add(_frame(len(done), rng, camera))
    assert len(frames) == len(done)
    assert len(builder.frames()) == len(done) + 1


def test_empty_builder_gives_an_empty_record() -> None:
    frames = DriveFramesBuilder(max_slope=0.1).frames()
    assert len(frames) == 0
    assert frames.stage_s.shape == (0, len(STAGES))
    assert frames.fit.cov.shape == (0, 3, 3)
