"""Reading never writes beside the input: every command on every format leaves it as it was.

``slt recover`` is checked too: it reads damaged inputs, which must stay as they were.

The input folder is made read-only (``chmod a-w``), but tests often run as root, where
permissions do not bind; so each case compares the folder's listing, modes, sizes, modification
times and content hashes before and after the command. One case also runs as an unprivileged
user, where the permissions do bind.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import stat
import subprocess
import sys
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path
from types import SimpleNamespace

import pytest
from typer.testing import CliRunner

from superlane_tools.cli.app import app

runner = CliRunner()
Snapshot = dict[str, tuple[int, int, int, str]]

ROS2 = "bags/ros2_format_fixtures"
REAL_INPUTS = {
    "ros1": "bags/ros1_robot_localization/test2.bag",
    "ros2-sqlite3": f"{ROS2}/sqlite3/talker",
    "ros2-mcap": f"{ROS2}/mcap/talker",
    "can": "can_logs/ford_fusion/camera_off_connection.log",
    "nmea": "gnss/nmea.log",
}
COMMANDS = ("info", "cat", "extract", "filter", "recover", "reprocess", "batch")
FAST = {"info", "cat", "extract", "filter", "recover"}
"""Commands that take well under a second a case; reprocess and batch cases are slow."""


def snapshot(folder: Path) -> Snapshot:
    """Return every entry under ``folder``: mode, size, mtime (ns) and SHA-256 of files."""
    found: Snapshot = {}
    for path in sorted([folder, *folder.rglob("*")]):
        st = path.lstat()
        digest = hashlib.sha256(path.read_bytes()).hexdigest() if path.is_file() else "dir"
        found[str(path.relative_to(folder))] = (st.st_mode, st.st_size, st.st_mtime_ns, digest)
    return found


def _set_writable(folder: Path, writable: bool) -> None:
    for path in [folder, *folder.rglob("*")]:
        mode = path.stat().st_mode
        bits = stat.S_IWUSR | stat.S_IWGRP | stat.S_IWOTH
        path.chmod(mode | stat.S_IWUSR if writable else mode & ~bits)


def _args(command: str, recording: Path, out: Path, kind: str) -> list[str]:
    if command in {"info", "cat"}:
        return [command, str(recording)]
    if command in {"filter", "recover"}:
        target = {"mcap": "f.mcap", "ros1": "f.bag"}.get(kind, "f_bag")
        return [command, str(recording), "-o", str(out / target)]
    if command == "reprocess":
        run = str(out / "run")
        return ["reprocess", str(recording), "-o", run, "--no-plots", "--camera", "sim_default"]
    if command == "batch":
        into = str(out / "batch")
        return ["batch", str(recording), "-o", into, "--job", "extract", "--workers", "1"]
    return [command, str(recording), "-o", str(out / "x")]


@pytest.fixture
def inputs(
    tmp_path: Path,
    drive: SimpleNamespace,
    make_drives: Callable[..., list[Path]],
    request: pytest.FixtureRequest,
) -> Iterator[Callable[[str], Path]]:
    """Return ``make(kind)``: a copy of one input of that kind, alone in a read-only folder."""

    def make(kind: str) -> Path:
        folder = tmp_path / "inputs" / kind
        folder.mkdir(parents=True)
        if kind == "mcap":  # real JPEG frames, CAN and GNSS: reprocess runs every stage
            (src,) = make_drives(1)
            path = folder / src.name
            shutil.move(src, path)
        elif kind == "ros2-own":
            path = Path(drive.write_to(folder / "drive_ros2", "ros2"))
        else:
            realdata: Path = request.getfixturevalue("realdata")  # skips when absent
            src = realdata / REAL_INPUTS[kind]
            path = folder / src.name
            if src.is_dir():
                shutil.copytree(src, path)
            else:
                shutil.copy2(src, path)
        _set_writable(folder, False)
        return path

    yield make
    if (tmp_path / "inputs").exists():
        _set_writable(tmp_path / "inputs", True)


def _check(kind: str, command: str, inputs: Callable[[str], Path], tmp_path: Path) -> None:
    recording = inputs(kind)
    folder = recording.parent
    before = snapshot(folder)
    out = tmp_path / "out"
    out.mkdir()
    result = runner.invoke(app, _args(command, recording, out, kind))
    assert "Traceback" not in result.output, result.output
    assert result.exit_code in {0, 1, 2, 3}, result.output
    assert snapshot(folder) == before, f"{command} changed {folder}: {result.output[-500:]}"


KINDS = ("mcap", "ros2-own", *REAL_INPUTS)
CASES = [
    pytest.param(kind, command, marks=() if command in FAST else pytest.mark.slow)
    for kind in KINDS
    for command in COMMANDS
]
# A fast representative of the slow commands, on the format that used to write beside its input.
CASES += [pytest.param("ros2-sqlite3", "reprocess", id="fast-reprocess")]


@pytest.mark.parametrize(("kind", "command"), CASES)
def test_command_leaves_the_input_unchanged(
    kind: str, command: str, inputs: Callable[[str], Path], tmp_path: Path
) -> None:
    _check(kind, command, inputs, tmp_path)


def test_snapshot_sees_a_new_entry(tmp_path: Path) -> None:
    """The comparison itself can fail: an added ``-wal`` file changes the snapshot."""
    (tmp_path / "a.db3").write_bytes(b"x")
    before = snapshot(tmp_path)
    (tmp_path / "a.db3-wal").write_bytes(b"")
    assert snapshot(tmp_path) != before


@pytest.fixture
def shared_tmp() -> Iterator[Path]:
    """A temporary folder outside pytest's base folder (private to root): others may enter."""
    root = Path(tempfile.mkdtemp(prefix="slt-ro-input-"))
    root.chmod(0o755)
    yield root
    _set_writable(root, True)
    shutil.rmtree(root)


def test_unprivileged_user_reads_a_read_only_sqlite3_bag(shared_tmp: Path, realdata: Path) -> None:
    """As a user who may not write the folder, ``slt cat`` still reads the whole bag."""
    if os.geteuid() != 0 or shutil.which("setpriv") is None:
        pytest.skip("needs root and setpriv to run a command as an unprivileged user")
    bag = shared_tmp / "talker"
    shutil.copytree(realdata / REAL_INPUTS["ros2-sqlite3"], bag)
    for path in [bag, *bag.rglob("*")]:
        path.chmod(0o555 if path.is_dir() else 0o444)
    before = snapshot(bag)
    repo = Path(__file__).resolve().parents[2]
    nobody = ["setpriv", "--reuid=65534", "--regid=65534", "--clear-groups", sys.executable]
    env = {**os.environ, "HOME": "/nonexistent", "PYTHONPATH": str(repo)}
    probe = subprocess.run(
        [*nobody, "-c", "import superlane_tools.cli.app"],
        env=env,
        cwd="/",
        capture_output=True,
        text=True,
        check=False,
    )
    if probe.returncode != 0:
        last = (probe.stderr.strip().splitlines() or ["?"])[-1]
        pytest.skip(f"the unprivileged user cannot import this install: {last}")
    done = subprocess.run(
        [*nobody, "-c", "from superlane_tools.cli.app import main; main()", "cat", str(bag)],
        env=env,
        cwd="/",
        capture_output=True,
        text=True,
        check=False,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.count("/topic") == 10
    assert snapshot(bag) == before
