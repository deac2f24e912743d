"""The drive's typed record and KPI sequences: frame rate, camera-less record, segments."""

from __future__ import annotations

import numpy as np
import pytest

from superlane_tools.corridor import TimeSegment
from superlane_tools.drive import ReprocessConfig
from superlane_tools.drive.finalize import kpi_segments
from superlane_tools.drive.record import no_camera_frames
from superlane_tools.reporting import layout as tables


def test_frame_rate_ignores_shared_log_times() -> None:
    # A bridge that batches frames gives some frames the same log time: only real steps count.
    t_ns = np.array([0, 0, 100_000_000, 100_000_000, 200_000_000, 300_000_000], dtype=np.int64)
    frames = no_camera_frames(t_ns)
    assert frames.frame_rate_hz() == pytest.approx(10.0)
    assert no_camera_frames(np.zeros(3, dtype=np.int64)).frame_rate_hz(12.5) == 12.5


def test_no_camera_record_is_empty_and_read_only() -> None:
    frames = no_camera_frames(np.arange(5, dtype=np.int64) * 66_666_667)
    assert len(frames) == 5
    assert not frames.decoded.any()
    assert np.isnan(frames.fit.curvature_per_m).all()
    assert frames.stage_s.shape == (5, len(tables.STAGES))
    with pytest.raises(ValueError, match="read-only"):
        frames.fit.curvature_per_m[0] = 1.0
    assert frames.stage_totals() == {
        **dict.fromkeys(tables.STAGES, 0.0),
        **{f"cpu_{s}": 0.0 for s in tables.STAGES},
    }


def test_kpi_segments_windows_and_given_times() -> None:
    cfg = ReprocessConfig().with_overrides({"kpi.window_s": 2.0, "kpi.category": "hwy"})
    t_ns = np.arange(100, dtype=np.int64) * 100_000_000  # 10 s at 10 Hz
    windows = kpi_segments(cfg, t_ns, 10.0, None)
    assert [(s.start, s.stop) for s in windows] == [(k, k + 20) for k in range(0, 100, 20)]
    assert {s.category for s in windows} == {"hwy"}
    given = [TimeSegment(1.0, 3.0, "ramp")]
    (only,) = kpi_segments(cfg, t_ns, 10.0, given)
    assert (only.start, only.stop, only.category) == (10, 30, "ramp")
