"""Reprocess with CAN as real vehicles have it: km/h speed, two buses, IMU, wrong DBC."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from superlane_tools.can import CanError
from superlane_tools.commands.reprocess import reprocess
from superlane_tools.drive.config import ReprocessConfig
from superlane_tools.simulation.drive import simulate_drive
from superlane_tools.simulation.sensors import VehicleOptions, dbc_path

pytestmark = pytest.mark.slow  # whole reprocess runs; run with -m slow


FAST = ReprocessConfig().with_overrides(
    {"output.example_frames": 0, "output.plots": False, "output.annotations": False}
)


@pytest.fixture(scope="module")
def drives(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """The same 4 s drive twice: m/s on one bus, and km/h + IMU + Mobileye on a second bus."""
    root = tmp_path_factory.mktemp("vehicle")
    plain = root / "plain.mcap"
    kph = root / "kph.mcap"
    simulate_drive("highway_curves", 4.0, 5, "mcap", 320, 180, False, plain)
    options = VehicleOptions(speed_kph=True, imu=True, second_bus=True)
    simulate_drive("highway_curves", 4.0, 5, "mcap", 320, 180, False, kph, vehicle=options)
    return plain, kph


def test_kph_drive_on_two_buses_has_identical_availability(drives, tmp_path: Path) -> None:
    plain, kph = drives
    reprocess(plain, tmp_path / "plain", FAST)
    bound = FAST.with_overrides(
        {
            "can.dbcs": [
                f"can={dbc_path('slt_vehicle_kph.dbc')}",
                f"can1={dbc_path('slt_mobileye_lanes.dbc')}",
            ]
        }
    )
    result = reprocess(kph, tmp_path / "kph", bound)
    assert result.status == "ok"
    a = pd.read_parquet(tmp_path / "plain" / "availability_frames.parquet")
    b = pd.read_parquet(tmp_path / "kph" / "availability_frames.parquet")
    assert len(a) == len(b) > 0
    assert (a["available"].to_numpy() == b["available"].to_numpy()).all()
    assert np.allclose(a["speed_mps"], b["speed_mps"], atol=0.01, equal_nan=True)
    signals = pd.read_parquet(tmp_path / "kph" / "can_signals.parquet")
    assert set(signals["bus"]) == {"/can/rx", "/can1/rx"}
    # The colliding id 0x180 of the second bus is not decoded as vehicle speed.
    speed = signals[signals["signal"] == "VehicleSpeed"]
    assert set(speed["bus"]) == {"/can/rx"}
    curv_a = pd.read_parquet(tmp_path / "plain" / "curvature.parquet")
    curv_b = pd.read_parquet(tmp_path / "kph" / "curvature.parquet")
    assert np.allclose(curv_a["mobileye_curvature"], curv_b["mobileye_curvature"], equal_nan=True)


def test_plain_dbcs_on_every_bus_misread_the_colliding_id(drives, tmp_path: Path) -> None:
    _, kph = drives
    every_bus = FAST.with_overrides(
        {"can.dbcs": [dbc_path("slt_vehicle_kph.dbc"), dbc_path("slt_mobileye_lanes.dbc")]}
    )
    reprocess(kph, tmp_path / "all", every_bus)
    signals = pd.read_parquet(tmp_path / "all" / "can_signals.parquet")
    speed = signals[signals["signal"] == "VehicleSpeed"]
    assert set(speed["bus"]) == {"/can/rx", "/can1/rx"}  # why buses must be modelled


def test_unknown_speed_unit_is_a_clear_error(drives, tmp_path: Path) -> None:
    plain, _ = drives
    text = Path(dbc_path("slt_vehicle.dbc")).read_text(encoding="utf-8")
    no_unit = tmp_path / "no_unit.dbc"
    no_unit.write_text(text.replace('[0|655.35] "m/s"', '[0|655.35] "furlong"'), encoding="utf-8")
    cfg = FAST.with_overrides({"can.dbcs": [str(no_unit), dbc_path("slt_mobileye_lanes.dbc")]})
    with pytest.raises(CanError, match=r"VehicleSpeed.*used as speed.*furlong"):
        reprocess(plain, tmp_path / "bad", cfg)
    fixed = cfg.with_overrides({"can.speed_unit": "m/s"})
    assert reprocess(plain, tmp_path / "fixed", fixed).status == "ok"


def test_wrong_dbc_makes_reprocess_partial(drives, tmp_path: Path, realdata: Path) -> None:
    plain, _ = drives
    cfg = FAST.with_overrides({"can.dbcs": [str(realdata / "dbc/opendbc/toyota_adas.dbc")]})
    result = reprocess(plain, tmp_path / "wrong", cfg)
    assert result.status == "partial"
    assert any("no CAN id matched by any DBC" in s.detail for s in result.skipped)
