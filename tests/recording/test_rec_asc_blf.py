"""Vector ASC and BLF CAN logs, written with python-can's own writers, read back by slt."""

from __future__ import annotations

from pathlib import Path

import can
import pandas as pd
import pytest
from typer.testing import CliRunner

from superlane_tools.cli.app import app
from superlane_tools.recording import open_recording

T0 = 1_700_000_000.0


def _write_log(path: Path) -> list[can.Message]:
    msgs = [
        can.Message(
            timestamp=T0 + 0.01 * k,
            arbitration_id=0x180 if k % 2 else 0x18FEF100,
            is_extended_id=not k % 2,
            data=bytes([k, k + 1, 0, 0, 0, 0, 0, 0]),
            channel=0,
        )
        for k in range(20)
    ]
    writer = can.ASCWriter(path) if path.suffix == ".asc" else can.BLFWriter(path)
    for msg in msgs:
        writer.on_message_received(msg)
    writer.stop()
    return msgs


@pytest.mark.parametrize("name", ["drive.asc", "drive.blf"])
def test_asc_and_blf_logs_stream_and_extract(tmp_path: Path, name: str) -> None:
    path = tmp_path / name
    written = _write_log(path)
    with open_recording(path) as rec:
        got = list(rec.messages())
    assert len(got) == len(written)
    assert [m.data.id for m in got] == [m.arbitration_id for m in written]
    assert [bool(m.data.is_extended) for m in got] == [m.is_extended_id for m in written]
    assert bytes(got[3].data.data)[:2] == bytes([3, 4])
    assert all(m.msgtype == "can_msgs/msg/Frame" for m in got)
    res = CliRunner().invoke(app, ["extract", str(path), "--out", str(tmp_path / "out")])
    assert res.exit_code == 0, res.output
    raw = pd.read_parquet(tmp_path / "out" / "can_raw.parquet")
    assert raw["can_id"].tolist() == [m.arbitration_id for m in written]
