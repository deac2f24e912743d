"""Reader plug-ins chosen by content, the one decoding step, injected MCAP decoder factories."""

from __future__ import annotations

import json
import shutil
from collections.abc import Callable
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import pytest
from mcap.decoder import DecoderFactory
from mcap.records import Schema

from superlane_tools.recording import RecordingError, find_reader, open_recording
from superlane_tools.recording.base import SkipLog
from superlane_tools.recording.canlog_source import decode_raw_message
from superlane_tools.recording.decoding import decode_messages
from superlane_tools.recording.nmea_source import decode_nmea_message
from superlane_tools.records import RawMessage, Skipped

SAMPLE = Path(__file__).resolve().parents[2] / "fixtures" / "sample_drive.mcap"
CANDUMP = Path("can_logs") / "ford_fusion" / "car_50km.log"
NMEA = Path("gnss") / "nmea.log"


def _keys(path: Path) -> list[tuple[str, int]]:
    with open_recording(path) as rec:
        return [(m.topic, m.log_time_ns) for m in rec.messages()]


# -- plug-ins chosen by content -------------------------------------------------------------


@pytest.mark.parametrize("name", ["drive.bag", "drive.log", "drive", "drive.db3", "drive.txt"])
def test_mcap_with_a_wrong_name_is_read_as_mcap(tmp_path: Path, name: str) -> None:
    renamed = tmp_path / name
    shutil.copyfile(SAMPLE, renamed)
    assert find_reader(renamed).name == "mcap"
    assert _keys(renamed) == _keys(SAMPLE)


def test_ros1_bag_named_mcap_is_read_as_ros1(drive: SimpleNamespace, tmp_path: Path) -> None:
    bag = drive.write("drive.bag", "ros1")
    renamed = tmp_path / "drive.mcap"
    shutil.copyfile(bag, renamed)
    assert find_reader(renamed).name == "ros1"
    assert _keys(renamed) == _keys(bag)


@pytest.mark.realdata
@pytest.mark.parametrize("name", ["gps.txt", "gps", "gps.nmea"])
def test_nmea_log_with_another_text_name_is_read_as_nmea(
    realdata: Path, tmp_path: Path, name: str
) -> None:
    renamed = tmp_path / name
    shutil.copyfile(realdata / NMEA, renamed)
    assert find_reader(renamed).name == "nmea"
    assert _keys(renamed) == _keys(realdata / NMEA)


@pytest.mark.realdata
def test_candump_and_ros2_folders_are_recognised(realdata: Path) -> None:
    assert find_reader(realdata / CANDUMP).name == "canlog"
    folder = realdata / "bags" / "ros2_format_fixtures" / "sqlite3" / "talker"
    assert find_reader(folder).name == "ros2"


@pytest.mark.parametrize(
    ("name", "content", "message"),
    [
        ("notes.bag", b"#not a bag\n", "notes.bag is not a recording: its content is not bag$"),
        ("notes.mcap", b"hello", "notes.mcap is not a recording: its content is not mcap$"),
        ("notes.db3", b"hello", "notes.db3 is not a recording: its content is not db3$"),
        ("notes.dat", b"\x00\x01hello", "notes.dat is not a recording: unrecognised content; "),
        ("notes.log", b"just words\n", "notes.log is not a recording: unrecognised content; "),
    ],
)
def test_unknown_file_gives_one_clear_error(
    tmp_path: Path, name: str, content: bytes, message: str
) -> None:
    path = tmp_path / name
    path.write_bytes(content)
    with pytest.raises(RecordingError, match=message):
        open_recording(path)


def test_folder_without_metadata_and_missing_path_give_clear_errors(tmp_path: Path) -> None:
    with pytest.raises(RecordingError, match=r"a folder without metadata\.yaml; expected an MCAP"):
        open_recording(tmp_path)
    with pytest.raises(RecordingError, match="does not exist"):
        open_recording(tmp_path / "missing.mcap")


# -- the shared decoding step, for each source kind -----------------------------------------


def _copy_mcap_with_a_bad_payload(src: Path, out: Path, topic: str) -> int:
    """Copy an MCAP file message by message, the second message of ``topic`` garbled."""
    from mcap.reader import make_reader
    from mcap.writer import Writer

    total = 0
    with src.open("rb") as handle, out.open("wb") as sink:
        reader = make_reader(handle)
        writer = Writer(sink)
        writer.start()
        schemas: dict[int, int] = {}
        channels: dict[int, int] = {}
        seen = 0
        for schema, channel, msg in reader.iter_messages(log_time_order=True):
            assert schema is not None
            if schema.id not in schemas:
                schemas[schema.id] = writer.register_schema(
                    schema.name, schema.encoding, schema.data
                )
            if channel.id not in channels:
                channels[channel.id] = writer.register_channel(
                    channel.topic, channel.message_encoding, schemas[schema.id]
                )
            data = msg.data
            if channel.topic == topic:
                seen += 1
                if seen == 2:
                    data = b"\x00\x01\x00\x00\x07"  # a CDR header and nothing more
            writer.add_message(channels[channel.id], msg.log_time, data, msg.publish_time)
            total += 1
        writer.finish()
    return total


def test_mcap_undecodable_message_is_skipped_and_counted_once(tmp_path: Path) -> None:
    bad = tmp_path / "bad.mcap"
    total = _copy_mcap_with_a_bad_payload(SAMPLE, bad, "/gnss/fix")
    with open_recording(bad) as rec:
        got = list(rec.messages())
        skipped = rec.skipped
    assert len(got) == total - 1
    assert skipped == [Skipped("undecodable message", _bad_detail(skipped), 1)]
    assert skipped[0].detail.startswith("/gnss/fix (sensor_msgs/msg/NavSatFix): ")


def _bad_detail(skipped: list[Skipped]) -> str:
    assert len(skipped) == 1
    return skipped[0].detail


def _copy_bag_with_a_bad_payload(src: Path, out: Path, kind: str, topic: str) -> int:
    """Copy a ROS bag connection by connection, the second message of ``topic`` garbled."""
    from rosbags.rosbag1 import Writer as Writer1
    from rosbags.rosbag2 import Writer as Writer2

    from superlane_tools.recording.rosbag_source import RosbagRecording

    total = 0
    with RosbagRecording(src) as rec:
        writer: Any = Writer1(out) if kind == "ros1" else Writer2(out, version=9)
        with writer:
            conns = {}
            for conn in rec.connections:
                if kind == "ros1":
                    conns[conn.id] = writer.add_connection(
                        conn.topic, conn.msgtype, msgdef=conn.msgdef.data, md5sum=conn.digest
                    )
                else:
                    conns[conn.id] = writer.add_connection(
                        conn.topic, conn.msgtype, typestore=rec.typestore
                    )
            seen = 0
            for conn, log_time, data in rec.connection_messages():
                if conn.topic == topic:
                    seen += 1
                    if seen == 2:
                        data = b"\x01\x02"  # noqa: PLW2901 - the garbled copy
                writer.write(conns[conn.id], log_time, data)
                total += 1
    return total


@pytest.mark.parametrize(("kind", "name"), [("ros1", "bad.bag"), ("ros2", "bad_ros2")])
def test_bag_undecodable_message_is_skipped_and_counted_once(
    drive: SimpleNamespace, tmp_path: Path, kind: str, name: str
) -> None:
    src = drive.write("drive.bag" if kind == "ros1" else "drive_ros2", kind)
    bad = tmp_path / name
    total = _copy_bag_with_a_bad_payload(src, bad, kind, "/gnss/fix")
    with open_recording(bad) as rec:
        got = list(rec.messages())
        skipped = rec.skipped
    assert len(got) == total - 1
    assert [(s.what, s.n_items) for s in skipped] == [("undecodable message", 1)]
    assert skipped[0].detail.startswith("/gnss/fix (sensor_msgs/msg/NavSatFix): ")


def _decode_with_one_garbled(
    path: Path, decoder: Callable[[RawMessage], Any], garbage: bytes
) -> tuple[int, list[Any], list[Skipped], list[Any]]:
    """Decode a log's raw messages in the shared step, the tenth one garbled."""
    with open_recording(path) as rec:
        raws = list(rec.raw_messages())
        expected = [m.data for m in rec.messages()]
    intact = list(decode_messages(((None, r) for r in raws), lambda k, r: decoder, SkipLog()))
    raws[10] = raws[10]._replace(payload=garbage)
    skips = SkipLog()
    got = list(decode_messages(((None, r) for r in raws), lambda k, r: decoder, skips))
    assert [m.data for m in intact] == expected  # the source decodes through this very step
    return len(raws), got, skips.items(), expected


@pytest.mark.realdata
@pytest.mark.parametrize(
    ("rel", "decoder", "garbage", "detail"),
    [
        (CANDUMP, decode_raw_message, b"\x01", "can0 (can_msgs/msg/Frame): ValueError"),
        (NMEA, decode_nmea_message, b"no sentence", "nmea (sensor_msgs/msg/NavSatFix): ValueError"),
    ],
    ids=["can", "nmea"],
)
def test_log_undecodable_message_is_skipped_and_counted_once(
    realdata: Path,
    rel: Path,
    decoder: Callable[[RawMessage], Any],
    garbage: bytes,
    detail: str,
) -> None:
    total, got, skipped, expected = _decode_with_one_garbled(realdata / rel, decoder, garbage)
    assert len(got) == total - 1
    assert [m.data for m in got] == expected[:10] + expected[11:]
    assert skipped == [Skipped("undecodable message", detail, 1)]


# -- injected MCAP decoder factories --------------------------------------------------------


class _CsvFactory(DecoderFactory):
    """Decodes a made-up ``x-csv`` message encoding: ``lat,lon`` text."""

    def decoder_for(
        self, message_encoding: str, schema: Schema | None
    ) -> Callable[[bytes], Any] | None:
        if message_encoding != "x-csv":
            return None

        def decode(data: bytes) -> SimpleNamespace:
            lat, lon = (float(v) for v in data.decode().split(","))
            return SimpleNamespace(latitude=lat, longitude=lon)

        return decode


def _write_csv_mcap(path: Path) -> None:
    from mcap.writer import Writer

    with path.open("wb") as sink:
        writer = Writer(sink)
        writer.start()
        schema = writer.register_schema("x.LatLon", "x-csv-schema", b"lat,lon")
        channel = writer.register_channel("/fix_csv", "x-csv", schema)
        for i in range(5):
            t = 1_700_000_000_000_000_000 + i * 100_000_000
            writer.add_message(channel, t, f"48.{i},11.5".encode(), t)
        writer.finish()


def test_injected_decoder_factory_decodes_a_new_encoding(tmp_path: Path) -> None:
    path = tmp_path / "csv.mcap"
    _write_csv_mcap(path)
    with open_recording(path) as rec:
        assert list(rec.messages()) == []
        assert [(s.what, s.n_items) for s in rec.skipped] == [("unknown message type", 5)]
    with open_recording(path, decoder_factories=[_CsvFactory()]) as rec:
        got = list(rec.messages())
        assert rec.skipped == []
    assert [m.data.latitude for m in got] == [48.0, 48.1, 48.2, 48.3, 48.4]
    assert {m.msgtype for m in got} == {"x.LatLon"}


class _CountingRos2Factory(DecoderFactory):
    """Wraps mcap_ros2's factory and counts the payloads it decodes."""

    def __init__(self) -> None:
        from mcap_ros2.decoder import DecoderFactory as Ros2Factory

        self.decoded: list[str] = []
        self._inner = Ros2Factory()

    def decoder_for(
        self, message_encoding: str, schema: Schema | None
    ) -> Callable[[bytes], Any] | None:
        decoder = self._inner.decoder_for(message_encoding, schema)
        if decoder is None or schema is None or schema.name != "sensor_msgs/msg/NavSatFix":
            return None
        inner = decoder

        def decode(data: bytes) -> Any:
            self.decoded.append(schema.name)
            return inner(data)

        return decode


def test_injected_decoder_factory_comes_before_the_built_in_ones() -> None:
    factory = _CountingRos2Factory()
    with open_recording(SAMPLE, decoder_factories=[factory]) as rec:
        fixes = list(rec.messages(["/gnss/fix"]))
    with open_recording(SAMPLE) as rec:
        plain = list(rec.messages(["/gnss/fix"]))
    assert len(factory.decoded) == len(fixes) == len(plain) > 0
    assert [(m.log_time_ns, m.stamp_ns, m.data.latitude) for m in fixes] == [
        (m.log_time_ns, m.stamp_ns, m.data.latitude) for m in plain
    ]


def test_injected_decoder_factory_that_fails_names_itself(tmp_path: Path) -> None:
    class Broken(DecoderFactory):
        def decoder_for(
            self, message_encoding: str, schema: Schema | None
        ) -> Callable[[bytes], Any] | None:
            raise ValueError("cannot parse " + json.dumps(message_encoding))

    path = tmp_path / "csv.mcap"
    _write_csv_mcap(path)
    with open_recording(path, decoder_factories=[Broken()]) as rec:
        assert list(rec.messages()) == []
        (skip,) = rec.skipped
    assert skip.what == "unknown message type"
    assert skip.n_items == 5
    assert "Broken cannot decode 'x.LatLon': ValueError" in skip.detail
