"""`slt recover` on real damaged files: the output reads back as `slt cat` reads the input."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
from typer.testing import CliRunner

from superlane_tools.cli.app import app

runner = CliRunner()
ROOT = Path(__file__).resolve().parents[3]
SAMPLE = ROOT / "fixtures" / "sample_drive.mcap"
ROS1 = "bags/ros1_robot_localization/test2.bag"
ROS2_SQLITE = "bags/ros2_format_fixtures/sqlite3"


def _cat(path: Path) -> list[str]:
    """What ``slt cat --json --full-bytes`` prints: every message, payload bytes included."""
    result = runner.invoke(app, ["cat", "--json", "--full-bytes", str(path)])
    assert result.exit_code in {0, 3}, result.output
    return result.stdout.splitlines()


def _recover(src: Path, out: Path, *extra: str) -> tuple[int, str, str]:
    result = runner.invoke(app, ["recover", str(src), "-o", str(out), *extra])
    assert "Traceback" not in result.output
    return result.exit_code, result.stdout, result.stderr


def _cut(src: Path, dst: Path, fraction: float) -> Path:
    data = src.read_bytes()
    dst.write_bytes(data[: int(len(data) * fraction)])
    return dst


def _zero(src: Path, dst: Path, fraction: float, size: int = 4096) -> Path:
    data = bytearray(src.read_bytes())
    at = int(len(data) * fraction)
    data[at : at + size] = bytes(size)
    dst.write_bytes(bytes(data))
    return dst


def _recover_damaged(src: Path, tmp_path: Path, how: str, suffix: str) -> tuple[Path, Path, str]:
    """Cut ``src`` in half or zero 4 KiB at 40 %, recover it; return (damaged, out, stderr)."""
    damaged = tmp_path / f"damaged{suffix}"
    if how == "cut":
        _cut(src, damaged, 0.5)
    else:
        _zero(src, damaged, 0.4)
    out = tmp_path / f"rec{suffix}"
    code, _, err = _recover(damaged, out)
    assert code == 3, err
    _check_recovered(damaged, out)
    return damaged, out, err


def _check_recovered(damaged: Path, out: Path) -> None:
    """The output is complete (no loss when read again) and equal to the damaged input's read."""
    expected = _cat(damaged)
    assert expected, "nothing readable: the damage is too large for this test"
    again = runner.invoke(app, ["cat", "--json", "--full-bytes", str(out)])
    assert again.exit_code == 0, again.output  # a valid file: nothing lost reading it
    assert again.stdout.splitlines() == expected


@pytest.fixture
def sample() -> Path:
    assert SAMPLE.is_file(), "fixtures/sample_drive.mcap is tracked: a clone always has it"
    return SAMPLE


@pytest.mark.parametrize("how", ["cut", "zeroed"])
def test_mcap_sample_drive(sample: Path, tmp_path: Path, how: str) -> None:
    from mcap.reader import make_reader

    _, out, err = _recover_damaged(sample, tmp_path, how, ".mcap")
    assert err.count("slt: skipped:") == 1
    with out.open("rb") as handle:
        summary = make_reader(handle).get_summary()
    assert summary is not None
    assert summary.chunk_indexes  # indexed
    assert not (tmp_path / ".rec.mcap.partial").exists()


def test_mcap_json_names_the_lost_topics(sample: Path, tmp_path: Path) -> None:
    damaged = _zero(sample, tmp_path / "damaged.mcap", 0.4)
    code, out, _ = _recover(damaged, tmp_path / "rec.mcap", "--json")
    assert code == 3
    doc = json.loads(out)
    assert doc["format"] == "mcap"
    assert doc["messages_written"] == len(_cat(damaged))
    (loss,) = doc["lost"]
    assert loss["what"] == "corrupt chunk"
    assert loss["messages"] == sum(t["n_messages"] for t in loss["topics"]) > 0
    assert all(t["start_ns"] < t["stop_ns"] for t in loss["topics"])


@pytest.mark.parametrize("nth", [1, -2])
def test_mcap_garbled_chunk_header_loses_that_chunk_only(
    sample: Path, tmp_path: Path, nth: int
) -> None:
    """Issue 27 fuzz recover-mcap-garble-8397/-16812: 16 garbled bytes in a chunk's header.

    The scan read on at the next chunk of the (intact) chunk index, as ``slt cat`` does: the
    output holds everything cat reads, and the loss is that one chunk, counted per topic.
    """
    from mcap.reader import make_reader

    with sample.open("rb") as handle:
        summary = make_reader(handle).get_summary()
    assert summary is not None
    bad = sorted(summary.chunk_indexes, key=lambda ci: ci.chunk_start_offset)[nth]
    data = bytearray(sample.read_bytes())
    at = bad.chunk_start_offset + 33  # the chunk CRC and its compression name's length
    data[at : at + 16] = b"\xff" * 16
    damaged = tmp_path / "damaged.mcap"
    damaged.write_bytes(bytes(data))
    code, out, err = _recover(damaged, tmp_path / "rec.mcap", "--json")
    assert code == 3, err
    assert "truncated" not in err
    (loss,) = json.loads(out)["lost"]
    assert loss["what"] == "corrupt chunk"
    assert loss["messages"] == sum(t["n_messages"] for t in loss["topics"]) > 0
    _check_recovered(damaged, tmp_path / "rec.mcap")
    assert len(_cat(damaged)) + loss["messages"] == len(_cat(sample))


def test_intact_recording_exits_0(sample: Path, tmp_path: Path) -> None:
    out = tmp_path / "rec.mcap"
    code, _, err = _recover(sample, out)
    assert code == 0, err
    assert "slt: skipped" not in err
    _check_recovered(sample, out)


@pytest.mark.realdata
@pytest.mark.parametrize("how", [pytest.param("cut", marks=pytest.mark.slow), "zeroed"])
def test_ros1_real_bag(realdata: Path, tmp_path: Path, how: str) -> None:
    _recover_damaged(realdata / ROS1, tmp_path, how, ".bag")


@pytest.mark.realdata
def test_ros2_sqlite3_split_fixture(realdata: Path, tmp_path: Path) -> None:
    """rosbag2's split wbag with its last file cut: the other files and the rest are kept."""
    damaged = tmp_path / "wbag"
    shutil.copytree(realdata / ROS2_SQLITE / "wbag", damaged)
    db3 = sorted(damaged.glob("*.db3"))[-1]
    db3.chmod(0o644)
    data = db3.read_bytes()
    db3.write_bytes(data[: len(data) * 6 // 10])
    out = tmp_path / "rec"
    code, _, err = _recover(damaged, out)
    assert code == 3, err
    assert "slt: skipped: unreadable sqlite3 rows" in err
    _check_recovered(damaged, out)
    assert next(out.glob("*.db3"))  # same storage


@pytest.mark.parametrize(
    ("name", "message"),
    [("rec.bag", "is written to OUT.mcap"), ("exists.mcap", "exists; pass --overwrite")],
)
def test_bad_output_is_usage_error(sample: Path, tmp_path: Path, name: str, message: str) -> None:
    (tmp_path / "exists.mcap").write_bytes(b"")
    code, _, err = _recover(sample, tmp_path / name)
    assert code == 2
    assert message in err


def test_nothing_readable_is_error(tmp_path: Path) -> None:
    src = tmp_path / "empty.mcap"
    src.write_bytes(b"\x89MCAP0\r\n" + bytes(64))
    code, _, err = _recover(src, tmp_path / "rec.mcap")
    assert code == 1, err
    assert "no readable message" in err
    assert not (tmp_path / "rec.mcap").exists()
