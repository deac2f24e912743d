"""Messages and exit codes at the edges (issue 35): empty files, folders, runs that are not
there, a ROS 2 bag without its messages, a full disk, and a first run that explains itself."""

from __future__ import annotations

import os
import resource
import sqlite3
import subprocess
import sys
from pathlib import Path

import pytest
from typer.testing import CliRunner

from superlane_tools.cli import app
from superlane_tools.cli._common import progress
from superlane_tools.commands.reprocess.entry import TIMES_WIDTH, report_line, times_line
from superlane_tools.recording import messages as m
from superlane_tools.recording.writers import open_writer

runner = CliRunner()
T0 = 1_700_000_000_000_000_000


@pytest.mark.parametrize("command", ["info", "cat", "reprocess", "extract", "convert"])
def test_an_empty_file_is_called_empty(command: str, tmp_path: Path) -> None:
    empty = tmp_path / "drive.mcap"
    empty.write_bytes(b"")
    out = ["-o", str(tmp_path / "out.mcap" if command == "convert" else tmp_path / "out")]
    res = runner.invoke(
        app, [command, str(empty), *(out if command not in {"info", "cat"} else [])]
    )
    assert res.exit_code == 1, res.output
    assert "empty file (0 bytes)" in res.stderr
    assert not (tmp_path / "out").exists()


def test_convert_on_a_folder_says_it_is_a_folder(tmp_path: Path) -> None:
    folder = tmp_path / "logs"
    folder.mkdir()
    res = runner.invoke(app, ["convert", str(folder), "-o", str(tmp_path / "o.mcap")])
    assert res.exit_code == 1
    assert res.stderr.startswith(f"slt: error: {folder} is a folder; convert takes files")


def test_compare_on_a_recording_says_run_reprocess_first(tmp_path: Path) -> None:
    rec = tmp_path / "drive.mcap"
    rec.write_bytes(b"\x89MCAP0\r\n")
    res = runner.invoke(app, ["compare", str(rec), str(rec), "-o", str(tmp_path / "c")])
    assert res.exit_code == 1, res.output
    assert "not a reprocess run folder: run slt reprocess first" in res.stderr
    assert not (tmp_path / "c").exists()


def _bag_without_messages(path: Path) -> Path:
    with open_writer(path, "ros2") as writer:
        writer.add_topic("/fix", "sensor_msgs/msg/NavSatFix")
        for i in range(20):
            t = T0 + i * 100_000_000
            writer.write("/fix", t, m.navsatfix(t, "gnss", 48.0, 11.0, 500.0))
    (db,) = path.glob("*.db3")
    with sqlite3.connect(db) as conn:
        conn.execute("DROP TABLE messages")
    return path


@pytest.mark.parametrize("command", ["info", "cat"])
def test_a_bag_without_its_messages_table_says_so(command: str, tmp_path: Path) -> None:
    bag = _bag_without_messages(tmp_path / "bag")
    res = runner.invoke(app, [command, str(bag)])
    assert res.exit_code == 1, res.output  # nothing readable: an error, not a partial result
    lines = res.stderr.splitlines()
    assert lines[0].startswith("slt: skipped: unreadable sqlite3 rows (20): bag.db3:")
    assert "(the messages table is missing)" in lines[0]
    assert "/fix: 20 of 20 lost" in lines[0]
    assert lines[1] == f"slt: error: {bag}: no message is readable (what was lost is above)"


def _limit_file_size() -> None:
    resource.setrlimit(resource.RLIMIT_FSIZE, (0, 0))  # every write fails: a full disk


def test_batch_on_a_full_disk_is_one_error_line(tmp_path: Path) -> None:
    rec = tmp_path / "d.mcap"
    with open_writer(rec, "mcap") as writer:
        writer.add_topic("/fix", "sensor_msgs/msg/NavSatFix")
        writer.write("/fix", T0, m.navsatfix(T0, "gnss", 48.0, 11.0, 500.0))
    cli = "from superlane_tools.cli.app import main; main()"
    args = ["batch", "d.mcap", "--out", "out", "--job", "extract", "--workers", "1"]
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[2])}
    done = subprocess.run(
        [sys.executable, "-c", cli, *args],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        env=env,
        preexec_fn=_limit_file_size,
        check=False,
        timeout=120,
    )
    assert done.returncode == 1, done.stderr
    lines = done.stderr.splitlines()
    assert lines == [f"slt: error: cannot write {Path('out') / '.batch.lock'}: File too large"]


def test_phases_are_labelled_and_never_0_of_unknown(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setenv("SLT_PROGRESS_INTERVAL_S", "0")
    with progress("reprocess", unit="frames") as bar:
        bar.phase("self-check on 16 frames")
        bar.phase("self-check on 16 frames", note="compiling lane-fit kernels")
        bar.phase("pass")
        bar.update(5, 10)
        bar.phase("report: tables, plots, report")
    lines = capsys.readouterr().err.splitlines()
    assert lines[0].startswith("slt: progress: self-check on 16 frames 0 s")
    assert lines[1].startswith("slt: progress: self-check on 16 frames compiling lane-fit kernels")
    assert any(line.startswith("slt: progress: pass 5/10 frames (50%)") for line in lines)
    assert lines[-1].startswith("slt: progress: report: tables, plots, report")
    assert not any(" 0/" in line or "/?" in line for line in lines)


def test_the_times_line_fits_in_100_characters() -> None:
    timings = {
        "total": 123.4,
        "pass_wall": 120.0,
        "post": 3.4,
        "cpu_total": 300.0,
        "decode": 12.0,
        "segmentation": 185.8,
        "corridor_net": 40.2,
        "hough": 20.0,
        "lane_fit": 30.5,
        "corridor_geometry": 8.0,
        **{f"cpu_{k}": 10.0 for k in ("decode", "segmentation", "hough", "lane_fit")},
    }
    line = times_line(timings, 18.1)
    assert len(line) <= TIMES_WIDTH
    assert line == (
        "times: 123.4 s wall, 18.1 frames/s; stage sums: segmentation 185.8 s, corridor_net 40.2 s"
    )  # the longest first, as many as fit
    assert times_line({"total": 2.0}, 5.0) == "times: 2.0 s wall, 5.0 frames/s"


def test_the_last_line_names_the_report_and_one_number_per_method() -> None:
    counts = (("super", 240, 237, 0), ("corridor_net", 240, 240, 0), ("mobileye", 240, 0, 240))
    line = report_line(Path("runs/sample_drive"), counts)
    assert line == (
        "report: runs/sample_drive/report.html -- SUPER 98.8 %, Corridor net 100.0 % of frames "
        "available; availability unknown (no speed): Mobileye"
    )
    assert report_line(Path("r"), ()) == "report: r/report.html"
