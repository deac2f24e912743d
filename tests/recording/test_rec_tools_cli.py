"""`slt cat`, `slt filter` and `slt dbc show` on real files and small written recordings."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

from superlane_tools.cli.app import app
from superlane_tools.recording import messages as m
from superlane_tools.recording import open_recording
from superlane_tools.recording.writers import open_writer

runner = CliRunner()
T0 = 1_700_000_000_000_000_000


def _drive(path: Path) -> Path:
    with open_writer(path, "mcap", chunk_size=2048) as w:
        w.add_topic("/can", "can_msgs/msg/Frame")
        w.add_topic("/fix", "sensor_msgs/msg/NavSatFix")
        w.add_topic("/camera/image/compressed", "sensor_msgs/msg/CompressedImage")
        for i in range(50):
            t = T0 + i * 100_000_000
            w.write("/can", t, m.can_frame(t, 0x123, bytes([i])))
            w.write("/fix", t, m.navsatfix(t, "gnss", 48.0 + i * 1e-5, 11.0, 500.0))
            w.write("/camera/image/compressed", t, m.compressed_image(t, "cam", "jpeg", b"x" * 500))
        w.add_metadata("vehicle", {"name": "car"})
    return path


def test_cat_real_ros1_bag_json_lines_and_time_range(realdata: Path) -> None:
    bag = realdata / "bags" / "ros1_robot_localization" / "test1.bag"
    result = runner.invoke(
        app, ["cat", str(bag), "-t", "^/fix$", "--json", "--start", "10", "--end", "12"]
    )
    assert result.exit_code == 0, result.output
    lines = [json.loads(line) for line in result.stdout.splitlines()]
    assert 3 <= len(lines) <= 7  # ~2.5 Hz over 2 s
    first = lines[0]
    assert first["msgtype"] == "sensor_msgs/msg/NavSatFix"
    assert 42.3 < first["data"]["latitude"] < 42.4
    assert "STATUS_FIX" not in first["data"]["status"]  # constants are not fields
    t = [line["log_time_ns"] for line in lines]
    assert t == sorted(t)
    assert t[-1] - t[0] < 2_000_000_000


@pytest.mark.parametrize("storage", ["mcap", "sqlite3"])
def test_cat_rosbag2_fixtures(realdata: Path, storage: str) -> None:
    bag = realdata / "bags" / "ros2_format_fixtures" / storage / "talker"
    result = runner.invoke(app, ["cat", str(bag), "-t", "^/topic$", "-n", "3"])
    assert result.exit_code == 0, result.output
    lines = result.stdout.splitlines()
    assert len(lines) == 3
    assert all("[std_msgs/msg/String]" in line and "Hello, world!" in line for line in lines)


def test_cat_can_log_and_absolute_start(realdata: Path) -> None:
    log = realdata / "can_logs" / "ford_fusion" / "nothing.log"
    first = runner.invoke(app, ["cat", str(log), "--json", "-n", "1"])
    assert first.exit_code == 0, first.output
    t0 = json.loads(first.stdout)["log_time_ns"]
    later = runner.invoke(app, ["cat", str(log), "--json", "-n", "1", "--start", str(t0 + 10**9)])
    assert later.exit_code == 0, later.output
    rec = json.loads(later.stdout)
    assert rec["log_time_ns"] >= t0 + 10**9
    assert rec["msgtype"] == "can_msgs/msg/Frame"


def test_cat_bad_regex_and_no_match_are_usage_errors(tmp_path: Path) -> None:
    path = _drive(tmp_path / "d.mcap")
    bad = runner.invoke(app, ["cat", str(path), "-t", "("])
    assert bad.exit_code == 2
    assert bad.stderr.startswith("slt: error: cat: invalid topic regular expression")
    none = runner.invoke(app, ["cat", str(path), "-t", "^/nothing$"])
    assert none.exit_code == 2
    big = runner.invoke(app, ["cat", str(path), "-t", "image", "-n", "1", "--json"])
    assert json.loads(big.stdout)["data"]["data"] == {"bytes": 500}


def test_a_repeated_topic_option_adds_a_pattern(tmp_path: Path) -> None:
    """``-t A -t B`` keeps topics matching either, ``--exclude`` alike: the last one given
    must never silently replace the others."""
    path = _drive(tmp_path / "d.mcap")
    out = tmp_path / "two.mcap"
    kept = runner.invoke(app, ["filter", str(path), "-o", str(out), "-t", "^/can$", "-t", "^/fix$"])
    assert kept.exit_code == 0, kept.output
    with open_recording(out) as rec:
        assert {t.topic for t in rec.topics()} == {"/can", "/fix"}
    out = tmp_path / "one.mcap"
    args = ["filter", str(path), "-o", str(out), "--exclude", "image", "--exclude", "^/can$"]
    dropped = runner.invoke(app, args)
    assert dropped.exit_code == 0, dropped.output
    with open_recording(out) as rec:
        assert {t.topic for t in rec.topics()} == {"/fix"}
    cat = runner.invoke(app, ["cat", str(path), "--json", "-t", "^/can$", "-t", "^/fix$"])
    assert cat.exit_code == 0, cat.output
    assert {json.loads(line)["topic"] for line in cat.stdout.splitlines()} == {"/can", "/fix"}
    none = runner.invoke(app, ["cat", str(path), "-t", "^/a$", "-t", "^/b$"])
    assert none.exit_code == 2
    assert "no topic matches '^/a$' or '^/b$'" in none.stderr


def test_filter_trims_topics_and_time_and_keeps_metadata(tmp_path: Path) -> None:
    path = _drive(tmp_path / "d.mcap")
    out = tmp_path / "cut.mcap"
    args = [
        "filter",
        str(path),
        "-o",
        str(out),
        "--exclude",
        "image",
        "--start",
        "1",
        "--end",
        "2.5",
    ]
    result = runner.invoke(app, args)
    assert result.exit_code == 0, result.output
    with open_recording(out) as rec:
        topics = {t.topic: t.message_count for t in rec.topics()}
        assert topics == {"/can": 15, "/fix": 15}
        times = [msg.log_time_ns for msg in rec.messages(topics=["/fix"])]
        assert times[0] == T0 + 10 * 100_000_000
        fix = next(iter(rec.messages(topics=["/fix"])))
        assert fix.data.latitude == pytest.approx(48.0001)
    from mcap.reader import make_reader

    with out.open("rb") as handle:
        meta = [(r.name, dict(r.metadata)) for r in make_reader(handle).iter_metadata()]
    assert meta == [("vehicle", {"name": "car"})]
    again = runner.invoke(app, args)
    assert again.exit_code == 2
    assert "filter: " in again.stderr
    assert "exists; pass --overwrite" in again.stderr


def test_filter_refuses_outputs_it_cannot_copy_into(realdata: Path, tmp_path: Path) -> None:
    path = _drive(tmp_path / "d.mcap")
    as_bag = runner.invoke(app, ["filter", str(path), "-o", str(tmp_path / "x.bag")])
    assert as_bag.exit_code == 2
    assert "an MCAP filters to OUT.mcap" in as_bag.stderr
    bag = realdata / "bags" / "ros1_robot_localization" / "test1.bag"
    to_ros2 = runner.invoke(app, ["filter", str(bag), "-o", str(tmp_path / "folder")])
    assert to_ros2.exit_code == 2
    assert "ROS 1 bag filters to OUT.bag or OUT.mcap" in to_ros2.stderr
    log = realdata / "can_logs" / "ford_fusion" / "nothing.log"
    not_mcap = runner.invoke(app, ["filter", str(log), "-o", str(tmp_path / "x.mcap")])
    assert not_mcap.exit_code == 1
    assert "reads MCAP files and ROS bags" in not_mcap.stderr
    assert not list(tmp_path.glob("x*"))
    assert not (tmp_path / "folder").exists()


def _payloads(path: Path, topic: str) -> list[tuple[int, bytes]]:
    from superlane_tools.recording.scan import scan_mcap

    return [(x.log_time_ns, x.payload) for x in scan_mcap(path).messages([topic])]


@pytest.mark.parametrize("damage", ["truncated", "zeroed"])
def test_filter_salvages_a_damaged_mcap_like_recover(tmp_path: Path, damage: str) -> None:
    whole = _drive(tmp_path / "d.mcap").read_bytes()
    data = bytearray(whole[: len(whole) // 2] if damage == "truncated" else whole)
    if damage == "zeroed":
        at = len(whole) * 2 // 5
        data[at : at + 4096] = bytes(4096)
    src = tmp_path / "bad.mcap"
    src.write_bytes(bytes(data))
    out = tmp_path / "f.mcap"
    result = runner.invoke(app, ["filter", str(src), "-o", str(out), "-t", "^/fix$", "--end", "4"])
    assert result.exit_code == 3, result.output
    assert "slt: skipped: " in result.stderr
    end = T0 + 4_000_000_000
    want = [(t, p) for t, p in _payloads(src, "/fix") if t < end]
    assert 5 < len(want) < 40  # some lost to the damage, some past --end
    assert _payloads(out, "/fix") == want  # byte for byte, nothing readable lost
    with open_recording(out) as rec:
        assert {t.topic for t in rec.topics()} == {"/fix"}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.mcap", "d.mcap", "f.mcap"]


def test_filter_of_a_text_log_says_what_filter_reads(realdata: Path, tmp_path: Path) -> None:
    log = realdata / "can_logs" / "ford_fusion" / "nothing.log"
    res = runner.invoke(app, ["filter", str(log), "-o", str(tmp_path / "x.bag")])
    assert res.exit_code == 1
    assert "reads MCAP files and ROS bags" in res.stderr, res.stderr
    assert "OUT.mcap" not in res.stderr  # not "an MCAP filters to OUT.mcap"


def test_filter_real_rosbag2_mcap(realdata: Path, tmp_path: Path) -> None:
    src = next((realdata / "bags" / "ros2_format_fixtures" / "mcap" / "talker").glob("*.mcap"))
    out = tmp_path / "topic.mcap"
    result = runner.invoke(app, ["filter", str(src), "-o", str(out), "-t", "^/topic$"])
    assert result.exit_code == 0, result.output
    with open_recording(out) as rec:
        assert [t.topic for t in rec.topics()] == ["/topic"]
        texts = [msg.data.data for msg in rec.messages()]
    assert texts
    assert texts[0].startswith("Hello, world!")


def _bag_messages(path: Path) -> tuple[list[tuple[str, int, bytes]], dict[str, tuple[str, str]]]:
    """Read a bag with rosbags alone: sorted ``(topic, time, payload)`` and definitions by topic."""
    from rosbags.rosbag1 import Reader as Reader1
    from rosbags.rosbag2 import Reader as Reader2

    reader = Reader1(path) if path.suffix == ".bag" else Reader2(path)
    with reader:
        msgs = sorted((c.topic, t, bytes(d)) for c, t, d in reader.messages())
        defs = {c.topic: (c.msgtype, c.msgdef.data) for c in reader.connections}
    return msgs, defs


def _mcap_messages(path: Path) -> list[tuple[str, int, bytes]]:
    from mcap.reader import make_reader

    with path.open("rb") as handle:
        return sorted(
            (ch.topic, m.log_time, bytes(m.data))
            for _, ch, m in make_reader(handle).iter_messages()
        )


def test_filter_real_ros1_bag_to_bag_and_mcap_byte_identical(
    realdata: Path, tmp_path: Path
) -> None:
    bag = realdata / "bags" / "ros1_robot_localization" / "test1.bag"
    source, source_defs = _bag_messages(bag)
    t0 = min(t for _, t, _ in source)
    want = [m for m in source if m[0] == "/fix" and t0 + 10 * 10**9 <= m[1] < t0 + 20 * 10**9]
    assert 20 <= len(want) <= 30  # ~2.5 Hz over 10 s

    out = tmp_path / "fix.bag"
    cmd = ["filter", str(bag), "-o", str(out), "-t", "^/fix$", "--start", "10", "--end", "20"]
    result = runner.invoke(app, cmd)
    assert result.exit_code == 0, result.output
    got, defs = _bag_messages(out)
    assert got == want
    assert defs == {"/fix": source_defs["/fix"]}
    info = runner.invoke(app, ["info", str(out), "--json"])
    assert info.exit_code == 0, info.output
    assert '"/fix"' in info.stdout

    out_mcap = tmp_path / "no_imu.mcap"
    result = runner.invoke(app, ["filter", str(bag), "-o", str(out_mcap), "--exclude", "imu"])
    assert result.exit_code == 0, result.output
    assert _mcap_messages(out_mcap) == [m for m in source if "imu" not in m[0]]
    with open_recording(out_mcap) as rec:
        fix = next(iter(rec.messages(topics=["/fix"])))
        assert 42.3 < fix.data.latitude < 42.4
    assert runner.invoke(app, ["info", str(out_mcap)]).exit_code == 0


@pytest.mark.parametrize("storage", ["sqlite3", "mcap"])
def test_filter_real_rosbag2_split_bag_keeps_storage(
    realdata: Path, tmp_path: Path, storage: str
) -> None:
    src = realdata / "bags" / "ros2_format_fixtures" / storage / "wbag"
    source, _ = _bag_messages(src)
    out = tmp_path / "cut"
    result = runner.invoke(app, ["filter", str(src), "-o", str(out), "--exclude", "^(AAA|BBB)$"])
    assert result.exit_code == 0, result.output
    got, defs = _bag_messages(out)
    assert got == [m for m in source if m[0] not in {"AAA", "BBB"}]
    assert set(defs) == {m[0] for m in got}
    suffix = ".db3" if storage == "sqlite3" else ".mcap"
    assert [p.suffix for p in out.iterdir() if p.name != "metadata.yaml"] == [suffix]
    info = runner.invoke(app, ["info", str(out), "--json"])
    assert info.exit_code == 0, info.output
    assert not list(tmp_path.glob(".*partial"))


def test_filter_real_rosbag2_db3_time_range_and_wrong_format(
    realdata: Path, tmp_path: Path
) -> None:
    db3 = realdata / "bags" / "ros2_format_fixtures" / "sqlite3" / "talker" / "talker.db3"
    source, _ = _bag_messages(db3)
    t0 = min(t for _, t, _ in source)
    out = tmp_path / "talk"
    result = runner.invoke(
        app, ["filter", str(db3), "-o", str(out), "-t", "^/topic$", "--start", "1"]
    )
    assert result.exit_code == 0, result.output
    got, _ = _bag_messages(out)
    assert got == [m for m in source if m[0] == "/topic" and m[1] >= t0 + 10**9]
    assert 0 < len(got) < 10
    with open_recording(out) as rec:
        assert all(msg.data.data.startswith("Hello, world!") for msg in rec.messages())
    bad = runner.invoke(app, ["filter", str(db3), "-o", str(tmp_path / "x.bag")])
    assert bad.exit_code == 2
    assert "ROS 2 bag filters to" in bad.stderr
    assert not (tmp_path / "x.bag").exists()


def test_dbc_show_the_mobileye_dbc_cantools_refuses(realdata: Path) -> None:
    dbc = realdata / "dbc" / "mobileye" / "Mobileye.dbc"
    import cantools

    with pytest.raises(Exception):  # noqa: B017, PT011 - cantools' own error types vary by version
        cantools.database.load_file(str(dbc))
    result = runner.invoke(app, ["dbc", "show", str(dbc), "--json"])
    assert result.exit_code == 0, result.output
    doc = json.loads(result.stdout)
    assert any("latin-1" in r for r in doc["repairs"])
    lanes = {msg["id_hex"]: msg for msg in doc["messages"]}
    assert {"0x766", "0x767", "0x768", "0x769"} <= set(lanes)
    lane_type = next(s for s in lanes["0x766"]["signals"] if s["name"] == "Lane_Type")
    assert lane_type["choices"]
    text = runner.invoke(app, ["dbc", "show", str(dbc), "-m", "Left_Lane_A"])
    assert text.exit_code == 0
    assert "0x766 Left_Lane_A" in text.stdout
    assert "repair: decoded as latin-1" in text.stdout
    missing = runner.invoke(app, ["dbc", "show", str(dbc), "-m", "0x1"])
    assert missing.exit_code != 0
    assert "no message" in missing.stderr


def test_dbc_show_opendbc_units(realdata: Path) -> None:
    dbc = realdata / "dbc" / "opendbc" / "ford_lincoln_base_pt.dbc"
    result = runner.invoke(app, ["dbc", "show", str(dbc), "-m", "BrakeSysFeatures", "--json"])
    assert result.exit_code == 0, result.output
    sig = {s["name"]: s for s in json.loads(result.stdout)["messages"][0]["signals"]}
    assert sig["Veh_V_ActlBrk"]["unit"].lower().startswith("k")
