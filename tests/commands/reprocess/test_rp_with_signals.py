"""`slt reprocess --with-signals`: CAN signals and truth curves in annotations.mcap."""

from __future__ import annotations

import json
from pathlib import Path

from typer.testing import CliRunner

from superlane_tools.cli.app import app
from superlane_tools.recording import open_recording
from superlane_tools.simulation.drive import simulate_drive

runner = CliRunner()


def test_with_signals_adds_plottable_json_channels(tmp_path: Path) -> None:
    rec = tmp_path / "drive.mcap"
    simulate_drive("highway_curves", 2.0, 5, "mcap", 320, 180, False, rec, fps=10.0)
    out = tmp_path / "run"
    result = runner.invoke(
        app, ["reprocess", str(rec), "-o", str(out), "--no-plots", "--with-signals"]
    )
    assert result.exit_code in (0, 3), result.output
    from mcap.reader import make_reader

    with (out / "annotations.mcap").open("rb") as handle:
        summary = make_reader(handle).get_summary()
    assert summary is not None
    by_topic = {ch.topic: summary.schemas[ch.schema_id] for ch in summary.channels.values()}
    params = by_topic["/slt/lane_parameters"]
    assert params.encoding == "jsonschema"
    schema = json.loads(params.data)
    assert "curvature_per_m" in schema["properties"]
    assert by_topic["/slt/truth"].encoding == "jsonschema"
    speed = by_topic["/slt/signals/VehicleSpeed"]
    assert "VehicleSpeed" in json.loads(speed.data)["properties"]
    with open_recording(out / "annotations.mcap") as r:
        values = [m.data.VehicleSpeed for m in r.messages(topics=["/slt/signals/VehicleSpeed"])]
        truth = [m.data for m in r.messages(topics=["/slt/truth"])]
        n_ann = sum(1 for _ in r.raw_messages(topics=["/slt/annotations"]))
    assert len(values) > 50
    assert 15.0 < sum(values) / len(values) < 40.0  # m/s on a highway
    assert len(truth) == n_ann == 20
    assert any(t.rtk_curvature is not None for t in truth)
