"""Round trips: every writer format read back by open_recording and by the real clients."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from superlane_tools.recording import open_recording
from superlane_tools.recording.mcap_source import McapRecording
from superlane_tools.recording.rosbag_source import RosbagRecording

FORMATS = [
    ("drive.mcap", "mcap", "sqlite3"),
    ("drive_ros1.mcap", "mcap-ros1", "sqlite3"),
    ("drive.bag", "ros1", "sqlite3"),
    ("drive_sqlite", "ros2", "sqlite3"),
    ("drive_mcapstore", "ros2", "mcap"),
]
IDS = ["mcap", "mcap-ros1", "ros1", "ros2-sqlite3", "ros2-mcap"]


@pytest.mark.parametrize(("name", "fmt", "storage"), FORMATS, ids=IDS)
def test_round_trip_with_open_recording(
    drive: SimpleNamespace, name: str, fmt: str, storage: str
) -> None:
    path = drive.write(name, fmt, storage)
    with open_recording(path) as rec:
        assert isinstance(rec, McapRecording if fmt.startswith("mcap") else RosbagRecording)
        assert getattr(rec, "indexed", True)  # complete MCAP files are read through the index
        infos = {t.topic: t for t in rec.topics()}
        assert {t: i.msgtype for t, i in infos.items()} == drive.topics
        assert {t: i.message_count for t, i in infos.items()} == drive.counts
        msgs = list(rec.messages())
        assert rec.skipped == []
    assert len(msgs) == drive.total
    times = [msg.log_time_ns for msg in msgs]
    assert times == sorted(times)
    fixes = [msg for msg in msgs if msg.topic == "/gnss/fix"]
    assert [f.stamp_ns for f in fixes] == [
        drive.t0_ns + i * drive.step_ns - drive.stamp_lag_ns for i in range(drive.n_steps)
    ]
    assert fixes[3].data.latitude == pytest.approx(48.1 + 3e-6)
    assert fixes[0].data.status.status == 2
    frames = [msg.data for msg in msgs if msg.topic == "/can/raw"]
    assert frames[7].id == 0x415
    assert frames[7].dlc == 5
    assert bytes(frames[7].data)[:5] == bytes([7, 1, 2, 3, 4])
    image = next(msg.data for msg in msgs if msg.topic == "/camera/image/compressed")
    assert image.format == "jpeg"
    assert bytes(image.data) == b"\xff\xd8" + bytes(500)
    raw = [msg.data for msg in msgs if msg.topic == "/camera/image_raw"][1]
    pixels = np.frombuffer(bytes(raw.data), np.uint8).reshape(raw.height, raw.width)
    assert (pixels == 10).all()
    info = next(msg.data for msg in msgs if msg.topic == "/camera/camera_info")
    k = getattr(info, "K", None)  # ROS 1 field names are upper case
    assert list(np.asarray(k if k is not None else info.k, dtype=float))[:3] == [910.0, 0.0, 582.0]
    tf = next(msg.data for msg in msgs if msg.topic == "/tf_static")
    assert tf.transforms[0].child_frame_id == "camera"
    assert tf.transforms[0].transform.translation.z == pytest.approx(1.4)


@pytest.mark.parametrize(("name", "fmt", "storage"), FORMATS, ids=IDS)
def test_time_range_and_topic_filter(
    drive: SimpleNamespace, name: str, fmt: str, storage: str
) -> None:
    path = drive.write(name, fmt, storage)
    start = drive.t0_ns + 10 * drive.step_ns
    stop = drive.t0_ns + 20 * drive.step_ns
    with open_recording(path) as rec:
        fixes = list(rec.messages(topics=["/gnss/fix"], start_ns=start, stop_ns=stop))
        raws = list(rec.raw_messages(topics={"/can/raw"}, start_ns=start, stop_ns=stop))
    assert len(fixes) == 10
    assert all(start <= f.log_time_ns < stop for f in fixes)
    assert [r.topic for r in raws] == ["/can/raw"] * 10
    assert raws[0].encoding == ("ros1" if "ros1" in fmt else "cdr")
    assert raws[0].msgtype == "can_msgs/msg/Frame"


@pytest.mark.parametrize(("name", "fmt", "storage"), FORMATS, ids=IDS)
def test_peeked_stamps_match_decoded_stamps(
    drive: SimpleNamespace, name: str, fmt: str, storage: str
) -> None:
    path = drive.write(name, fmt, storage)
    with open_recording(path) as rec:
        decoded = [msg.stamp_ns for msg in rec.messages()]
        peeked = [rec.peek_stamp_ns(raw) for raw in rec.raw_messages()]  # type: ignore[attr-defined]
    assert peeked == decoded


@pytest.mark.parametrize(("name", "fmt"), [("a.mcap", "mcap"), ("b.mcap", "mcap-ros1")])
def test_mcap_reads_back_with_mcap_decoder_factories(
    drive: SimpleNamespace, name: str, fmt: str
) -> None:
    from mcap.reader import make_reader
    from mcap_ros1.decoder import DecoderFactory as Ros1Factory
    from mcap_ros2.decoder import DecoderFactory as Ros2Factory

    path = drive.write(name, fmt)
    with path.open("rb") as handle:
        reader = make_reader(handle, decoder_factories=[Ros2Factory(), Ros1Factory()])
        assert reader.get_header().library == "superlane-tools"
        decoded = list(reader.iter_decoded_messages(topics=["/gnss/fix"]))
    assert len(decoded) == drive.n_steps
    first = decoded[0].decoded_message
    assert first.longitude == pytest.approx(11.5)
    assert decoded[0].message.log_time == drive.t0_ns + 1


@pytest.mark.parametrize(
    ("name", "fmt", "storage"),
    [("c.bag", "ros1", "sqlite3"), ("d", "ros2", "sqlite3"), ("e", "ros2", "mcap")],
)
def test_bags_read_back_with_rosbags_anyreader(
    drive: SimpleNamespace, name: str, fmt: str, storage: str
) -> None:
    from rosbags.highlevel import AnyReader

    path = drive.write(name, fmt, storage)
    with AnyReader([path]) as reader:
        conns = [c for c in reader.connections if c.topic == "/can/raw"]
        frames = [reader.deserialize(raw, c.msgtype) for c, _, raw in reader.messages(conns)]
        header_def = reader.typestore.fielddefs["std_msgs/msg/Header"][1]
    assert [f.data[0] for f in frames] == list(range(drive.n_steps))
    # ROS 1 bags carry the genuine ROS 1 Header (with seq); ROS 2 bags the ROS 2 one
    assert (header_def[0][0] == "seq") == (fmt == "ros1")


@pytest.mark.parametrize(("name", "fmt", "storage"), FORMATS, ids=IDS)
def test_writers_are_deterministic(
    tmp_path: Path, drive: SimpleNamespace, name: str, fmt: str, storage: str
) -> None:
    first = drive.write(name, fmt, storage)
    (tmp_path / "again").mkdir()
    second = drive.write_to(tmp_path / "again" / name, fmt, storage)
    if first.is_dir():
        files = sorted(p.name for p in first.iterdir())
        assert files == sorted(p.name for p in second.iterdir())
        for rel in files:
            assert (first / rel).read_bytes() == (second / rel).read_bytes(), rel
    else:
        assert first.read_bytes() == second.read_bytes()


def test_writer_refuses_existing_path_and_cleans_up_on_error(drive: SimpleNamespace) -> None:
    from superlane_tools.recording import RecordingError, open_writer

    path = drive.write("x.mcap", "mcap")
    with pytest.raises(RecordingError, match="exists already"):
        open_writer(path, "mcap")
    broken = path.with_name("broken.mcap")
    with pytest.raises(RecordingError, match="was not added"), open_writer(broken, "mcap") as w:
        w.write("/nope", 1, object())
    assert not broken.exists()
    assert not list(path.parent.glob(".broken*"))


@pytest.mark.parametrize("compression", ["zstd", "lz4", "none"])
def test_mcap_chunk_compression(tmp_path: Path, compression: str) -> None:
    from mcap.reader import make_reader

    from superlane_tools.recording.messages import compressed_image
    from superlane_tools.recording.writers import open_writer

    path = tmp_path / f"{compression}.mcap"
    payloads = [bytes([k]) * 2000 for k in range(40)]
    with open_writer(path, "mcap", chunk_size=8192, compression=compression) as w:  # type: ignore[arg-type]
        w.add_topic("/cam", "sensor_msgs/msg/CompressedImage")
        for k, payload in enumerate(payloads):
            w.write("/cam", 1_000 + k, compressed_image(1_000 + k, "cam", "jpeg", payload))
    with path.open("rb") as handle:
        summary = make_reader(handle).get_summary()
    assert summary is not None
    assert len(summary.chunk_indexes) > 1
    expected = "" if compression == "none" else compression  # MCAP spells none ""
    assert {c.compression for c in summary.chunk_indexes} == {expected}
    with open_recording(path) as rec:
        assert [bytes(m.data.data) for m in rec.messages()] == payloads
        assert rec.skipped == []


def test_unknown_mcap_compression_is_refused(tmp_path: Path) -> None:
    from superlane_tools.recording.errors import RecordingError
    from superlane_tools.recording.writers import open_writer

    with pytest.raises(RecordingError, match="unknown MCAP chunk compression"):
        open_writer(tmp_path / "x.mcap", "mcap", compression="brotli")  # type: ignore[arg-type]
    assert not list(tmp_path.iterdir())
