"""Correctness under SIGKILL: a batch killed halfway and started again finishes cleanly."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import pandas as pd
import pytest

from superlane_tools.commands.batch import (
    MARKER,
    BatchParams,
    expand_inputs,
    read_status,
    run_batch,
)

SLT = (
    "from superlane_tools.cli.app import app\n"
    "from superlane_tools.cli import batch\n"
    "batch.register(app)\n"
    "app()\n"
)


def _batch(*args: str) -> list[str]:
    return [sys.executable, "-c", SLT, "batch", *args]


def _descendants(pid: int) -> list[int]:
    """Processes below ``pid`` (children, grandchildren, ...), from ``/proc``."""
    parents: dict[int, int] = {}
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:  # the process ended meanwhile
            continue
        parents[int(stat.parent.name)] = int(fields[1])
    found, frontier = [], [pid]
    while frontier:
        below = [child for child, parent in parents.items() if parent in frontier]
        found += below
        frontier = below
    return found


def _alive(pid: int) -> bool:
    """Whether ``pid`` runs (a zombie, dead but not yet reaped by init, counts as ended)."""
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


@pytest.mark.slow
def test_sigkill_halfway_then_resume(
    tmp_path: Path, make_drives: Callable[..., list[Path]]
) -> None:
    make_drives(18, 2)
    root = tmp_path / "out"
    args = _batch(
        str(tmp_path / "recs"),
        "--out",
        str(root),
        "--job",
        "extract",
        "--workers",
        "1",
        "--retries",
        "0",
    )
    proc = subprocess.Popen(args, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 60
    done: list[Path] = []
    while time.monotonic() < deadline and proc.poll() is None:
        done = list(root.glob("*/" + MARKER))
        if len(done) >= 6:
            break
        time.sleep(0.01)
    workers = _descendants(proc.pid)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    assert 6 <= len(done) < 18, "the kill did not land halfway"
    # the killed driver's fork server and workers do not outlive it
    assert workers, "no worker processes were seen"
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline and any(_alive(pid) for pid in workers):
        time.sleep(0.05)
    assert not [pid for pid in workers if _alive(pid)]

    result = subprocess.run(args, capture_output=True, text=True, timeout=120, check=False)
    assert result.returncode == 3, result.stderr  # 2 corrupt recordings: partial success
    assert "skipped" in result.stdout

    status = read_status(root)
    assert len(status) == 20
    assert status["recording_id"].is_unique
    assert status["recording"].is_unique
    assert sorted(status["result"].value_counts().items()) == [("failed", 2), ("ok", 18)]
    assert status["status"].eq("skipped").sum() >= len(done)
    failed = status[status["result"] == "failed"]
    assert failed["recording"].str.contains("corrupt_").all()
    assert failed["error"].str.contains("recording|MCAP|mcap|magic|record", regex=True).all()
    # every finished folder is complete (marker + all outputs), exactly once, nothing else
    folders = sorted(p.name for p in root.iterdir() if p.is_dir() and p.name != "summary")
    assert folders == sorted(status.loc[status["result"] == "ok", "recording_id"])
    for name in folders:
        marker = json.loads((root / name / MARKER).read_text())
        assert marker["status"] == "ok"
        frames = pd.read_parquet(root / name / "frames.parquet")
        assert len(frames) == 10
        assert frames["log_time_ns"].is_unique
        assert len(list((root / name / "frames").rglob("*.jpg"))) == 10
    assert not (root / ".tmp").exists()
    assert not list(root.rglob("*.tmp"))
    assert (root / "summary" / "report.md").is_file()


def test_resume_removes_half_written_files_of_a_killed_driver(
    tmp_path: Path, make_drives: Callable[..., list[Path]]
) -> None:
    make_drives(1)
    root = tmp_path / "out"
    params = BatchParams(root, "extract", workers=1, config={"frame_format": "none"})
    run_batch(expand_inputs([tmp_path / "recs"]), params)
    # what SIGKILL during the status or summary write leaves behind
    leftovers = [
        root / ".batch_status.parquet.k1ll3d.parquet.tmp",
        root / "summary" / ".report.md.k1ll3d.tmp",
    ]
    for path in leftovers:
        path.write_bytes(b"PAR1 half")
    again = run_batch(expand_inputs([tmp_path / "recs"]), params)
    assert again.counts["skipped"] == 1
    assert not [p for p in leftovers if p.exists()]
    assert not list(root.rglob("*.tmp"))
