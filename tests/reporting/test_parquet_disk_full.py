"""Parquet outputs on a full disk (issue 27 fuzz disk-full-reprocess-2000-10).

Writes past a size fail as on a full disk (``RLIMIT_FSIZE``: ``EFBIG``, the fuzz family's
mechanism), in a child process. pyarrow's writer whose close failed used to close again in its
``__del__`` and print the error as an ignored exception after ``slt: error:``.
"""

from __future__ import annotations

import os
import resource
import signal
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

_SINK = """
import sys
from pathlib import Path
import pyarrow as pa
from superlane_tools.drive.sinks import FrameTablesSink
from superlane_tools.reporting import OutputError, Provenance, write_table
from superlane_tools.reporting.layout import STREAMED_SCHEMAS

prov = Provenance(command="slt test", config={})
try:
    write_table(pa.table({"x": list(range(5000))}), Path("t.parquet"), prov)
except OutputError as err:
    print("table:", err, file=sys.stderr)
sink = FrameTablesSink({n: Path(f"{n}.parquet") for n in STREAMED_SCHEMAS}, prov, "", 0)
try:
    sink.close(True)
except OutputError as err:
    print("sink:", err, file=sys.stderr)
"""


def _limited(limit: int) -> None:
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))


def _run(args: list[str], cwd: Path, limit: int) -> subprocess.CompletedProcess[str]:
    env = dict(os.environ, PYTHONPATH=str(ROOT), COLUMNS="400")
    return subprocess.run(
        [sys.executable, *args],
        cwd=cwd,
        env=env,
        capture_output=True,
        text=True,
        preexec_fn=lambda: _limited(limit),  # only setrlimit
        timeout=300,
        check=False,
    )


def test_failed_parquet_writes_raise_one_error_and_leave_nothing(tmp_path: Path) -> None:
    done = _run(["-c", _SINK], tmp_path, 1000)
    assert done.returncode == 0, done.stderr
    lines = done.stderr.splitlines()
    assert [line.split(":")[0] for line in lines] == ["table", "sink"], done.stderr
    assert all("File too large" in line for line in lines)
    assert list(tmp_path.iterdir()) == []  # temp files removed, no target written


@pytest.mark.slow
def test_reprocess_on_a_full_disk_is_one_clean_error(tmp_path: Path) -> None:
    from superlane_tools.simulation.drive import simulate_drive

    simulate_drive("highway_curves", 1.0, 3, "mcap", 160, 90, False, tmp_path / "d.mcap")
    before = sorted(p.name for p in tmp_path.iterdir())
    cli = "from superlane_tools.cli.app import main; main()"
    done = _run(["-c", cli, "reprocess", "d.mcap", "--out", "out", "--no-plots"], tmp_path, 5001)
    assert done.returncode == 1, done.stderr
    lines = [line for line in done.stderr.splitlines() if not line.startswith("slt: note:")]
    assert len(lines) == 1, done.stderr
    assert lines[0].startswith("slt: error: cannot write")
    assert "File too large" in lines[0]
    assert sorted(p.name for p in tmp_path.iterdir()) == before  # no staging folder left
