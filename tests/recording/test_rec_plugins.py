"""What the reader plug-ins declare reaches scan, recover, filter, batch discovery and info."""

from __future__ import annotations

import shutil
from pathlib import Path
from types import SimpleNamespace

from superlane_tools.commands.recover import recover
from superlane_tools.recording.open import (
    READERS,
    discovered,
    discovery_hint,
    fast_info,
    filtering_plugin,
    is_recording_folder,
    read_head,
    recovering_plugin,
    scanning_plugin,
)
from superlane_tools.recording.tools import filter_recording


def test_every_plug_in_declares_its_name_and_what_it_reads() -> None:
    names = [p.name for p in READERS]
    assert names == ["mcap", "ros1", "ros2", "canlog", "nmea", "video"]
    for plugin in READERS:
        assert plugin.label
        assert plugin.suffixes
        if plugin.recover is not None:  # recover writes the same format: it needs a name for it
            assert plugin.output_suffix is not None
    assert discovery_hint() == "*.mcap, *.bag, ROS 2 bags, CAN logs"


def test_the_table_answers_for_each_format(drive: SimpleNamespace) -> None:
    mcap = drive.write("drive.mcap", "mcap")
    bag = drive.write("drive.bag", "ros1")
    folder = drive.write("drive_ros2", "ros2")
    db3 = next(folder.glob("*.db3"))

    assert [scanning_plugin(read_head(p)) for p in (mcap, bag, db3)] == [*READERS[:2], None]
    assert [recovering_plugin(p) for p in (mcap, bag, folder, db3)] == [*READERS[:3], READERS[2]]
    assert [filtering_plugin(p).name for p in (mcap, bag, folder, db3)] == [
        "mcap",
        "ros1",
        "ros2",
        "ros2",
    ]
    assert [discovered(p) for p in (mcap, bag, folder, db3)] == [True, True, True, False]
    assert is_recording_folder(folder)
    assert not is_recording_folder(folder.parent)
    info = fast_info(mcap)
    assert info is not None
    assert info.has_statistics
    assert fast_info(bag) is None
    assert fast_info(folder) is None


def test_a_bag_under_another_name_is_filtered_and_recovered_as_a_bag(
    drive: SimpleNamespace, tmp_path: Path
) -> None:
    bag = drive.write("drive.bag", "ros1")
    renamed = tmp_path / "drive.dat"
    shutil.copyfile(bag, renamed)
    assert filtering_plugin(renamed).name == "ros1"

    filtered = filter_recording(renamed, tmp_path / "cut.bag", topics="/gnss")
    assert filtered.output_format == "ros1"
    assert filtered.counts == {"/gnss/fix": drive.counts["/gnss/fix"]}
    assert scanning_plugin(read_head(tmp_path / "cut.bag")) == READERS[1]

    result = recover(renamed, tmp_path / "copy.bag")
    assert result.format == "ros1"
    assert result.written == drive.counts
