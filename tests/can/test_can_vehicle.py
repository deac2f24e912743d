"""CAN as real vehicles have it: units, buses, DBC coverage, VAL_ labels, Mobileye validity."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from superlane_tools.can import (
    ALL_BUSES,
    BusDbc,
    CanError,
    MobileyeMapping,
    dbc_coverage,
    decode_buses,
    decode_frames,
    latency_by_xcorr,
    line_latency,
    load_dbc,
    mobileye_table,
    parse_dbc_spec,
    si_factor,
    to_si,
)
from superlane_tools.cli import app
from superlane_tools.recording.open import open_recording

FORD_PT = "dbc/opendbc/ford_lincoln_base_pt.dbc"


def _candump(path: Path) -> tuple[np.ndarray, list[bytes], np.ndarray]:
    ids, data, times = [], [], []
    for line in path.read_text().splitlines():
        stamp, _, frame = line.split()
        can_id, payload = frame.split("#")
        ids.append(int(can_id, 16))
        data.append(bytes.fromhex(payload))
        times.append(round(float(stamp.strip("()")) * 1e9))
    return np.array(ids), data, np.array(times, dtype=np.int64)


def test_ford_speed_in_kph_converts_to_metres_per_second(realdata: Path) -> None:
    ids, data, times = _candump(realdata / "can_logs/ford_fusion/car_60km.log")
    table = decode_frames(load_dbc(realdata / FORD_PT).database, ids, data, times)
    speed = table[table["signal"] == "Veh_V_ActlBrk"]
    unit = str(speed["unit"].iloc[0])
    assert unit == "kph"
    mps = to_si(speed["value"].to_numpy(), unit, "speed", "Veh_V_ActlBrk")
    assert 57.0 / 3.6 <= float(np.median(mps)) <= 58.5 / 3.6


@pytest.mark.parametrize(
    ("unit", "quantity", "factor"),
    [
        ("km/h", "speed", 1 / 3.6),
        ("MPH", "speed", 0.44704),
        ("m/s", "speed", 1.0),
        ("deg/s", "yaw_rate", np.pi / 180),
        ("rad/s", "yaw_rate", 1.0),
    ],
)
def test_unit_factors(unit: str, quantity: str, factor: float) -> None:
    assert si_factor(unit, quantity) == pytest.approx(factor)


@pytest.mark.parametrize("unit", ["", "counts", "rpm"])
def test_unknown_unit_on_a_used_signal_is_a_clear_error(unit: str) -> None:
    with pytest.raises(CanError, match="used as speed"):
        si_factor(unit, "speed", "Speed")


def test_dbc_spec_parsing() -> None:
    assert parse_dbc_spec("can0=pt.dbc") == (ALL_BUSES.replace("*", "can0"), Path("pt.dbc"))
    assert parse_dbc_spec("some/dir/pt.dbc").bus == ALL_BUSES
    with pytest.raises(CanError):
        parse_dbc_spec("can0=")


def test_comma2k19_two_buses_decode_with_their_own_dbc(realdata: Path, comma2k19: Path) -> None:
    pt = load_dbc(realdata / "dbc/opendbc/toyota_generator__toyota_2017.dbc")
    adas = load_dbc(realdata / "dbc/opendbc/toyota_adas.dbc")
    frames: dict[str, tuple[list[int], list[bytes], list[int]]] = {}
    with open_recording(comma2k19) as rec:
        for msg in rec.messages(topics=["/can0", "/can1"]):
            ids, data, times = frames.setdefault(msg.topic, ([], [], []))
            ids.append(int(msg.data.id))
            data.append(bytes(msg.data.data)[: int(msg.data.dlc)])
            times.append(msg.log_time_ns)
    arrays = {k: (np.array(i), d, np.array(t, np.int64)) for k, (i, d, t) in frames.items()}
    ids0 = set(arrays["/can0"][0].tolist())
    ids1 = set(arrays["/can1"][0].tolist())
    assert len(ids0 & ids1) == 5  # the real minute has five ids on both buses
    bound = [BusDbc("can0", "pt", pt), BusDbc("can1", "adas", adas)]
    table = decode_buses(arrays, bound)
    assert set(table["bus"]) == {"/can0", "/can1"}
    assert set(table.loc[table["bus"] == "/can0", "dbc"]) == {"pt"}
    assert set(table.loc[table["bus"] == "/can1", "dbc"]) == {"adas"}
    # Plain DBCs decode every bus: the colliding ids are decoded on both.
    both = decode_buses(arrays, [BusDbc(ALL_BUSES, "pt", pt)])
    shared = both[both["can_id"].isin(ids0 & ids1)]
    assert set(shared["bus"]) <= {"/can0", "/can1"}
    cover = dbc_coverage({k: v[0] for k, v in arrays.items()}, bound)
    assert cover.seen == len(ids0) + len(ids1)
    assert 0 < cover.matched < cover.seen
    assert "CAN ids matched" in cover.line()
    # VAL_ labels: the highway drive is in gear D.
    gear = table[(table["message"] == "GEAR_PACKET") & (table["signal"] == "GEAR")]
    assert len(gear) > 10
    assert set(gear["label"]) == {"D"}


def test_extract_two_buses_writes_a_bus_column(realdata: Path, comma2k19: Path, tmp_path: Path):
    dbc = realdata / "dbc/opendbc"
    result = CliRunner().invoke(
        app,
        [
            "extract",
            str(comma2k19),
            "--out",
            str(tmp_path),
            "--frames",
            "none",
            "--dbc",
            f"can0={dbc / 'toyota_generator__toyota_2017.dbc'}",
            "--dbc",
            f"can1={dbc / 'toyota_adas.dbc'}",
        ],
    )
    assert result.exit_code == 0, result.output
    assert "DBC coverage:" in result.output
    table = pd.read_parquet(tmp_path / "can_signals.parquet")
    assert {"bus", "label"} <= set(table.columns)
    assert table.groupby("bus")["dbc"].nunique().to_dict() == {"/can0": 1, "/can1": 1}


def test_wrong_dbc_is_exit_3_with_one_line(realdata: Path, tmp_path: Path) -> None:
    log = realdata / "can_logs/ford_fusion/car_50km.log"
    result = CliRunner().invoke(
        app,
        [
            "extract",
            str(log),
            "--out",
            str(tmp_path),
            "--dbc",
            str(realdata / "dbc/mobileye/Mobileye.dbc"),
        ],
    )
    assert result.exit_code == 3, result.output
    lines = [x for x in result.output.splitlines() if "no CAN id matched by any DBC" in x]
    assert len(lines) == 1
    assert "0 of 75 ids" in lines[0]


def _mobileye_frames(realdata: Path, qualities: list[tuple[int, int]]) -> pd.DataFrame:
    loaded = load_dbc(realdata / "dbc/mobileye/Mobileye.dbc")
    db = loaded.database
    ids, data, times = [], [], []
    for k, (q_left, q_right) in enumerate(qualities):
        t = k * 66_000_000
        for name, quality in (("Left_Lane_A", q_left), ("Right_Lane_A", q_right)):
            msg = db.get_message_by_name(name)
            values = {s.name: 0 for s in msg.signals}
            values.update(Quality=quality, Curve_Parameter_C2=-0.0005, Curve_Parameter_C0=1.7)
            ids.append(msg.frame_id)
            data.append(msg.encode(values, strict=False))
            times.append(t)
        lane = db.get_message_by_name("Lane")
        lane_values = {s.name: 0 for s in lane.signals}
        lane_values["Lane_Curvature"] = -0.001
        ids.append(lane.frame_id)
        data.append(lane.encode(lane_values, strict=False))
        times.append(t + 1000)
    return decode_frames(db, np.array(ids), data, np.array(times, np.int64))


def test_mobileye_low_quality_update_is_missing_not_zero(realdata: Path) -> None:
    signals = _mobileye_frames(realdata, [(3, 3), (1, 0), (3, 1), (0, 0)])
    table = mobileye_table(signals, MobileyeMapping())
    curv = table["curvature"].to_numpy()
    assert curv[0] == pytest.approx(0.001, rel=1e-2)  # -2*C2, right positive flipped
    assert np.isnan(curv[1])
    assert np.isnan(curv[3])
    assert curv[2] == pytest.approx(0.001, rel=1e-2)
    # 0x737 Lane_Curvature cross-checks 2*C2 in the same convention.
    assert table["lane_curvature"].to_numpy()[0] == pytest.approx(0.001, rel=1e-2)


def _lane_offsets(t: np.ndarray) -> np.ndarray:
    """Ego-line offsets (m) of a drive with centimetre wander and a lane change at 6 s."""
    wander = 0.08 * np.sin(2 * np.pi * t / 9.0)
    left = 1.8 + wander + np.where(t >= 6.0, -3.7, 0.0) + 3.7 * np.clip((t - 4.0) / 2.0, 0, 1)
    return np.stack([left, left - 3.7], axis=1)


@pytest.mark.parametrize("delay_s", [0.0, 0.1, 0.25])
def test_latency_by_cross_correlation_on_own_time_bases(delay_s: float) -> None:
    rng = np.random.default_rng(3)
    frames = np.arange(0, 20, 1 / 15)  # camera frames, the reference's time base
    sent = frames + delay_s  # each Mobileye update leaves delay_s after its frame
    reference = _lane_offsets(frames) + rng.normal(0, 0.02, (frames.size, 2))
    signal = _lane_offsets(frames) + rng.normal(0, 0.03, (frames.size, 2))
    est = latency_by_xcorr(frames, reference, sent, signal)
    # Resolved well below one frame period: the lag grid is not the frame grid.
    assert est.lag_s == pytest.approx(delay_s, abs=0.01)
    assert est.resolved
    assert est.correlation > 0.99


def test_latency_without_timing_features_is_not_resolved() -> None:
    rng = np.random.default_rng(4)
    frames = np.arange(0, 20, 1 / 15)
    wander = np.stack([0.08 * np.sin(2 * np.pi * frames / 9.0)] * 2, axis=1)
    est = latency_by_xcorr(frames, wander, frames + 0.1, wander + rng.normal(0, 0.03, wander.shape))
    assert not est.resolved  # slow centimetre wander under 3 cm noise: no timing reference


def _weaving(t: np.ndarray) -> np.ndarray:
    """Ego-line offsets (m) of a drive weaving in its lane all along (0.4 m, 2-5 s periods)."""
    centre = 0.4 * np.sin(2 * np.pi * t / 3.1) + 0.25 * np.sin(2 * np.pi * t / 4.7 + 1.0)
    centre += 0.15 * np.sin(2 * np.pi * t / 2.0)
    return np.stack([1.8 - centre, -1.9 - centre], axis=1)


def test_line_latency_resolves_repeated_lateral_motion() -> None:
    rng = np.random.default_rng(5)
    frames = np.arange(0, 60, 1 / 15)
    reference = _weaving(frames) + rng.normal(0, 0.02, (frames.size, 2))
    signal = _weaving(frames) + rng.normal(0, 0.03, (frames.size, 2))
    est = line_latency(frames, reference, frames + 0.1, signal, resolution_s=1 / 15)
    assert est.lag_s == pytest.approx(0.1, abs=0.01)
    assert est.resolved, est.unresolved


def test_line_latency_does_not_claim_one_relabelling() -> None:
    """One lane change whose ego relabelling Mobileye makes a frame later than SUPER."""
    rng = np.random.default_rng(6)
    frames = np.arange(0, 10, 1 / 15)
    reference = _lane_offsets(frames) + rng.normal(0, 0.02, (frames.size, 2))
    late = _lane_offsets(frames - 1 / 15) + rng.normal(0, 0.03, (frames.size, 2))
    raw = latency_by_xcorr(frames, reference, frames + 0.1, late)
    assert raw.resolved  # the step alone looks sharp: the old rule claimed +0.167 s
    est = line_latency(frames, reference, frames + 0.1, late, resolution_s=1 / 15)
    assert not est.resolved
    assert est.unresolved


def test_latency_search_is_bounded_when_frames_share_times() -> None:
    t = np.repeat(np.arange(0, 600, 0.5), 8)  # batched bridge: 8 frames per time stamp
    value = np.sin(t / 7.0)
    est = latency_by_xcorr(t, value, t + 0.5, value, max_lag_s=1e6, step_s=1e-9)
    assert np.isfinite(est.lag_s)  # at most MAX_LAGS lags, whatever the step and range
    with pytest.raises(CanError):
        latency_by_xcorr(t, value, t, np.stack([value, value], axis=1))
