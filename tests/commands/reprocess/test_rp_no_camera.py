"""Reprocess a real recording without a camera: the comma2k19 minute (two buses, GNSS, IMU)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from superlane_tools.commands.reprocess import reprocess
from superlane_tools.drive.config import ReprocessConfig
from superlane_tools.geo import trajectory_curvature

pytestmark = pytest.mark.slow  # whole reprocess runs; run with -m slow


@pytest.mark.realdata
def test_comma2k19_without_camera(realdata: Path, comma2k19: Path, tmp_path: Path) -> None:
    import pymap3d

    dbc = realdata / "dbc/opendbc"
    cfg = ReprocessConfig().with_overrides(
        {
            "can.dbcs": [
                f"can0={dbc / 'toyota_generator__toyota_2017.dbc'}",
                f"can1={dbc / 'toyota_adas.dbc'}",
            ],
            "can.speed_signal": "SPEED",  # kph in the DBC: converted to m/s
            "can.yaw_rate_signal": "",
            "rtk.imu_yaw_axis": "-z",  # the phone's z axis points down
        }
    )
    out = tmp_path / "run"
    result = reprocess(comma2k19, out, cfg)
    assert result.status == "ok"
    report = (out / "report.md").read_text()
    assert "no camera stream" in report
    assert "truth degraded: not RTK" in report
    signals = pd.read_parquet(out / "can_signals.parquet")
    assert set(signals["bus"]) == {"/can0", "/can1"}
    curv = pd.read_parquet(out / "curvature.parquet")
    assert 10.0 < np.nanmedian(curv["speed_mps"]) < 25.0
    # The yaw-rate reference agrees with comma's own fused trajectory (ECEF, 20 Hz).
    root = realdata / "comma2k19/segment/global_pose"
    t_fused = (np.load(root / "frame_times") * 1e9).round().astype(np.int64)
    pos = np.load(root / "frame_positions")
    lat0, lon0, alt0 = pymap3d.ecef2geodetic(*pos[0])
    e, n, _ = pymap3d.ecef2enu(pos[:, 0], pos[:, 1], pos[:, 2], lat0, lon0, alt0)
    t = curv["log_time_ns"].to_numpy(np.int64)
    fused = trajectory_curvature(t_fused, e, n, np.ones(t_fused.size, bool), t)
    ref = curv["dynamics_curvature"].to_numpy()
    both = fused.valid & np.isfinite(ref)
    assert both.sum() > 700
    rms = float(np.sqrt(np.mean((ref[both] - fused.curvature_per_m[both]) ** 2)))
    assert rms < 1.5e-4, rms
    summary = pd.read_parquet(out / "curvature_summary.parquet")
    dyn = summary[(summary["scope"] == "overall") & (summary["source"] == "dynamics")].iloc[0]
    assert dyn["n"] > 700  # compared with the (degraded) plain-GNSS truth
    assert bool(summary["truth_degraded"].all())
