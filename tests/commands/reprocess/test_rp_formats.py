"""`slt reprocess` on every recording format the simulator writes: the same drive, the same result.

One simulated drive written as MCAP, ROS 1 bag and ROS 2 folder gives the same lanes and the same
availability in each. Floats agree to 1e-9 relative, not bit for bit: the camera's extrinsics
travel as ``slt_camera`` metadata in MCAP but as a ``/tf_static`` quaternion in the bags, which
rounds at 1e-16 (measured: MCAP vs ROS 1 differ from the 15th digit; ROS 1 vs ROS 2 are
identical).
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from superlane_tools.cli.app import app
from superlane_tools.reporting.layout import RunLayout

FORMATS = {"mcap": "d.mcap", "ros1": "d.bag", "ros2": "d2"}
RTOL = 1e-9


@pytest.fixture(scope="module")
def runs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, RunLayout]:
    """The same 1 s drive in each format, reprocessed."""
    root = tmp_path_factory.mktemp("formats")
    sim = ["simulate", "--scenario", "highway_curves", "--duration", "1", "--seed", "3"]
    out: dict[str, RunLayout] = {}
    for fmt, name in FORMATS.items():
        rec = root / name
        res = CliRunner().invoke(
            app, [*sim, "--width", "320", "--height", "180", "--format", fmt, "--out", str(rec)]
        )
        assert res.exit_code == 0, res.output
        run = root / f"run_{fmt}"
        res = CliRunner().invoke(app, ["reprocess", str(rec), "--out", str(run), "--no-plots"])
        assert res.exit_code == 0, res.output
        out[fmt] = RunLayout(run)
    return out


@pytest.mark.parametrize("fmt", FORMATS)
def test_every_format_reprocesses(runs: dict[str, RunLayout], fmt: str) -> None:
    run = runs[fmt]
    assert len(pd.read_parquet(run.frames)) == 15
    assert len(pd.read_parquet(run.mobileye)) > 0
    assert len(pd.read_parquet(run.rtk)) > 0


def _assert_same(a: pd.DataFrame, b: pd.DataFrame, what: str) -> None:
    """Equal columns and rows; floats (also inside list columns) to :data:`RTOL`."""
    assert list(a.columns) == list(b.columns), what
    assert len(a) == len(b), what
    for col in a.columns:
        x, y = a[col], b[col]
        if x.dtype == object and len(x) and isinstance(x.iloc[0], np.ndarray | list):
            assert [len(v) for v in x] == [len(v) for v in y], f"{what}.{col}"
            x = pd.Series(np.concatenate([np.asarray(v) for v in x] or [np.empty(0)]))
            y = pd.Series(np.concatenate([np.asarray(v) for v in y] or [np.empty(0)]))
        if pd.api.types.is_float_dtype(x):
            np.testing.assert_allclose(x, y, rtol=RTOL, atol=0, err_msg=f"{what}.{col}")
        else:
            assert x.tolist() == y.tolist(), f"{what}.{col}"


@pytest.mark.parametrize("fmt", ["ros1", "ros2"])
def test_bags_give_the_lanes_and_availability_of_the_mcap(
    runs: dict[str, RunLayout], fmt: str
) -> None:
    mcap, bag = runs["mcap"], runs[fmt]
    lanes = [pd.read_parquet(r.lanes).drop(columns=["fit_time_ms"]) for r in (mcap, bag)]
    assert lanes[0]["offsets"].map(len).sum() > 0  # the drive has fitted lanes to compare
    _assert_same(*lanes, f"{fmt} lanes")
    for table in ("availability_frames", "availability_sequences"):
        pair = [pd.read_parquet(r.table(table)) for r in (mcap, bag)]
        _assert_same(*pair, f"{fmt} {table}")
