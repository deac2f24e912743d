"""Whole drives: recordings read by the real clients, ground truth files, determinism."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from superlane_tools.recording import open_recording
from superlane_tools.reporting import read_provenance
from superlane_tools.simulation.drive import (
    TOPIC_CAN,
    TOPIC_FIX,
    TOPIC_IMAGE,
    TOPIC_INFO,
    TOPIC_TF,
    DriveOutputs,
    simulate_drive,
)
from superlane_tools.simulation.errors import ScenarioError

TOPICS = {TOPIC_CAN, TOPIC_FIX, TOPIC_IMAGE, TOPIC_INFO, TOPIC_TF}


def _drive(out: Path, fmt: str = "mcap", labels: bool = False, seed: int = 3):  # type: ignore[no-untyped-def]
    return simulate_drive("highway_curves", 1.0, seed, fmt, 320, 180, labels, out, fps=5.0)


@pytest.mark.parametrize(("fmt", "name"), [("mcap", "d.mcap"), ("ros1", "d.bag"), ("ros2", "d")])
def test_recording_is_read_by_rosbags_and_the_project(tmp_path: Path, fmt: str, name: str) -> None:
    result = _drive(tmp_path / name, fmt)
    assert result.frames == 5
    with open_recording(result.outputs.recording) as rec:
        topics = {t.topic: t for t in rec.topics()}
        assert set(topics) == TOPICS
        images = [m for m in rec.messages() if m.topic == TOPIC_IMAGE]
    assert len(images) == 5
    assert bytes(images[0].data.data[:2]) == b"\xff\xd8"  # JPEG
    if fmt != "mcap":
        from rosbags.highlevel import AnyReader

        from superlane_tools.recording import default_typestore

        with AnyReader([result.outputs.recording], default_typestore=default_typestore()) as r:
            counts = {c.topic: c.msgcount for c in r.connections}
            fix = next(
                r.deserialize(raw, c.msgtype) for c, _, raw in r.messages() if c.topic == TOPIC_FIX
            )
        assert counts[TOPIC_IMAGE] == 5
        assert counts[TOPIC_FIX] == 11
        assert 48.0 < fix.latitude < 48.3
        assert fix.status.status == 2


def test_mcap_is_read_by_mcaps_reader_with_camera_metadata(tmp_path: Path) -> None:
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    result = _drive(tmp_path / "d.mcap")
    with result.outputs.recording.open("rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        n_can = 0
        for _, channel, _, msg in reader.iter_decoded_messages():
            if channel.topic == TOPIC_CAN:
                n_can += 1
                assert msg.id in {0x180, 0x181, 0x766, 0x767, 0x768, 0x769}
            if channel.topic == TOPIC_TF:
                tf = msg.transforms[0]
                assert tf.header.frame_id == "base_link"
                assert tf.transform.translation.z == 1.5
        f.seek(0)
        metadata = {m.name: m.metadata for m in make_reader(f).iter_metadata()}
    assert n_can > 100
    if "slt_camera" in metadata:  # needs RecordingWriter.add_metadata (recording layer)
        assert metadata["slt_camera"]["height_m"] == "1.5"


def test_ground_truth_files_beside_the_recording(tmp_path: Path) -> None:
    result = _drive(tmp_path / "g.mcap", labels=True)
    out = result.outputs
    assert out == DriveOutputs.beside(tmp_path / "g.mcap")
    df = pd.read_parquet(out.groundtruth)
    assert len(df) == 5
    assert df["frame_index"].tolist() == [0, 1, 2, 3, 4]
    assert (np.diff(df["t_ns"]) == 200_000_000).all()
    row = df.iloc[2]
    assert row["scenario"] == "highway_curves"
    assert (
        row["line_offset_m"][row["ego_left_line"]] > 0 > row["line_offset_m"][row["ego_right_line"]]
    )
    assert 3.6 < row["corridor_width_m"] < 3.8
    prov = read_provenance(out.groundtruth)
    assert prov["config"]["seed"] == 3
    assert prov["config"]["camera"]["intrinsics"]["width"] == 320
    lines = out.tusimple.read_text().splitlines()
    first = json.loads(lines[0])
    assert first["h_samples"][0] == 40
    assert len(first["h_samples"]) == 56
    assert first["raw_file"] == "frames/000000.jpg"
    assert (out.labels_dir / first["raw_file"]).is_file()
    assert len(list((out.labels_dir / "labels").glob("*.png"))) == 5
    assert len(list((out.labels_dir / "corridor").glob("*.png"))) == 5


def test_same_arguments_give_byte_identical_files(tmp_path: Path) -> None:
    a = _drive(tmp_path / "a" / "x.mcap", labels=True)
    b = _drive(tmp_path / "b" / "x.mcap", labels=True)
    c = _drive(tmp_path / "c" / "x.mcap", seed=4)
    for name in ("recording", "groundtruth", "tusimple"):
        pa_, pb = getattr(a.outputs, name), getattr(b.outputs, name)
        assert pa_.read_bytes() == pb.read_bytes(), name
    for f in sorted(a.outputs.labels_dir.rglob("*.png")):
        assert (
            f.read_bytes()
            == (b.outputs.labels_dir / f.relative_to(a.outputs.labels_dir)).read_bytes()
        )
    assert a.outputs.recording.read_bytes() != c.outputs.recording.read_bytes()


def test_existing_output_and_bad_requests_are_refused(tmp_path: Path) -> None:
    from superlane_tools.recording import RecordingError

    _drive(tmp_path / "x.mcap")
    with pytest.raises(RecordingError):
        _drive(tmp_path / "x.mcap")
    with pytest.raises(ScenarioError):
        simulate_drive("highway_curves", 1.0, 0, "avi", 320, 180, False, tmp_path / "y.avi")
    with pytest.raises(ScenarioError):
        simulate_drive("highway_curves", 1.0, 0, "mcap", 320, 20000, False, tmp_path / "y.mcap")
    with pytest.raises(ScenarioError):
        simulate_drive("highway_curves", -1.0, 0, "mcap", 320, 180, False, tmp_path / "y.mcap")
    assert not (tmp_path / "y.mcap").exists()
