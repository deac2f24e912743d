"""`slt reprocess` on every recording format the simulator writes (ROS 1 bag, ROS 2 folder)."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest
from typer.testing import CliRunner

from superlane_tools.cli.app import app


@pytest.mark.parametrize(("fmt", "name"), [("ros1", "d.bag"), ("ros2", "d2")])
def test_reprocess_bag_formats(tmp_path: Path, fmt: str, name: str) -> None:
    rec = tmp_path / name
    sim = ["simulate", "--scenario", "highway_curves", "--duration", "1", "--seed", "3"]
    res = CliRunner().invoke(
        app, [*sim, "--width", "320", "--height", "180", "--format", fmt, "--out", str(rec)]
    )
    assert res.exit_code == 0, res.output
    out = tmp_path / "run"
    res = CliRunner().invoke(app, ["reprocess", str(rec), "--out", str(out), "--no-plots"])
    assert res.exit_code == 0, res.output
    frames = pd.read_parquet(out / "frames.parquet")
    assert len(frames) == 15
    assert len(pd.read_parquet(out / "mobileye.parquet")) > 0
    assert len(pd.read_parquet(out / "rtk.parquet")) > 0
