"""``slt mine --criteria low_light`` on a reprocessed drive whose recording has dark frames.

A short simulated drive is rewritten with some camera frames darkened by a night gamma and
some washed out to low contrast (the JPEGs re-encoded in the MCAP), then reprocessed with the
oracle segmentation; mining must pick exactly those frames, from the recording's pixels.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from superlane_tools.cli.app import app
from superlane_tools.commands.reprocess import reprocess
from superlane_tools.drive.config import ReprocessConfig
from superlane_tools.reporting.run_folder import staged_run
from superlane_tools.simulation.drive import simulate_drive

runner = CliRunner()
DARK = range(8, 12)
"""Frames (of 24) given a night gamma."""
FLAT = range(16, 19)
"""Frames washed out towards mid-grey (low contrast)."""


def _night(image: np.ndarray) -> np.ndarray:
    return (255 * 0.4 * (image / 255.0) ** 2.2).astype(np.uint8)


def _washed_out(image: np.ndarray) -> np.ndarray:
    return (0.2 * image + 0.8 * 150).astype(np.uint8)


def _rewrite(src: Path, dst: Path) -> None:
    """Copy the MCAP, darkening / flattening the camera frames DARK / FLAT (in log order)."""
    import cv2
    from mcap.reader import make_reader
    from mcap.writer import Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    msgtype = "sensor_msgs/msg/CompressedImage"
    k = 0
    with src.open("rb") as fin, dst.open("wb") as fout:
        reader = make_reader(fin)
        summary = reader.get_summary()
        assert summary is not None
        writer: Any = Writer(fout)
        writer.start(reader.get_header().profile, reader.get_header().library)
        for known in summary.schemas.values():
            writer.register_schema(known.name, known.encoding, known.data)
        for ch in summary.channels.values():
            writer.register_channel(ch.topic, ch.message_encoding, ch.schema_id, ch.metadata)
        for schema, channel, message in reader.iter_messages(log_time_order=True):
            data: Any = message.data
            if schema is not None and schema.name == msgtype:
                if k in DARK or k in FLAT:
                    msg: Any = store.deserialize_cdr(data, msgtype)
                    image: Any = cv2.imdecode(np.asarray(msg.data), cv2.IMREAD_COLOR)
                    image = _night(image) if k in DARK else _washed_out(image)
                    ok, jpeg = cv2.imencode(".jpg", image)
                    assert ok
                    msg = dataclasses.replace(msg, data=jpeg.ravel())
                    data = store.serialize_cdr(msg, msgtype)
                k += 1
            writer.add_message(
                channel.id, message.log_time, data, message.publish_time, message.sequence
            )
        for record in reader.iter_metadata():
            writer.add_metadata(record.name, record.metadata)
        writer.finish()
    assert k == 24


@pytest.fixture(scope="module")
def night_run(
    tmp_path_factory: pytest.TempPathFactory, oracle_config: Callable[[Path], ReprocessConfig]
) -> Path:
    """A reprocess run of a 1.6 s drive whose recording has the DARK and FLAT frames."""
    root = tmp_path_factory.mktemp("night")
    day = root / "sim" / "day.mcap"
    day.parent.mkdir()
    simulate_drive("highway_straight", 1.6, 5, "mcap", 320, 180, True, day)
    rec = root / "drives" / "night.mcap"
    rec.parent.mkdir()
    _rewrite(day, rec)
    config = oracle_config(root / "sim" / "day_labels" / "labels")
    out = root / "run" / "night"
    with staged_run(out) as stage:
        assert reprocess(rec, stage, config, command="test night").frames == 24
    return out


def test_low_light_picks_exactly_the_dark_and_washed_out_frames(
    night_run: Path, tmp_path: Path
) -> None:
    out = tmp_path / "set"
    drives = night_run.parent.parent / "drives"
    args = ["mine", str(night_run), "-o", str(out), "--criteria", "low_light"]
    mined = runner.invoke(
        app, [*args, "--recordings", str(drives), "--max-frames", "24", "--min-gap-s", "0"]
    )
    assert mined.exit_code == 0, mined.output
    manifest = pd.read_parquet(out / "manifest.parquet")
    assert sorted(manifest["frame_index"]) == [*DARK, *FLAT]
    assert set(manifest["reasons"]) == {"low_light"}
    assert (manifest["low_light"] >= 0.5).all()
    for image in manifest["image"]:
        assert (out / image).is_file()


def test_low_light_without_the_recording_is_unscored_not_zero(
    night_run: Path, tmp_path: Path
) -> None:
    args = ["mine", str(night_run), "-o", str(tmp_path / "set"), "--criteria", "low_light"]
    mined = runner.invoke(app, [*args, "--recordings", str(tmp_path)])  # not there
    assert mined.exit_code == 3, mined.output
    assert "slt: skipped: low_light unscored: recording not found (24)" in mined.output
    assert pd.read_parquet(tmp_path / "set" / "manifest.parquet").empty
