"""``slt batch --engine ray`` on a two-node Ray cluster whose worker node is lost mid-batch."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pandas as pd
import pytest

from superlane_tools.commands.batch import MARKER

pytestmark = pytest.mark.slow  # a cluster of two nodes and a batch of 3 drives: a minute or more

ray = pytest.importorskip("ray")
cluster_utils = pytest.importorskip("ray.cluster_utils")

REPO = Path(__file__).resolve().parents[3]
SLT = [sys.executable, "-c", "from superlane_tools.cli.app import main; main()"]
FAST_DEATH = {"health_check_period_ms": 1000, "health_check_failure_threshold": 3}
"""The shorter health checks docs/batch.md suggests for a private cluster (dead after ~3 s)."""
LIMIT_S = 400.0
"""Generous: Ray starts slowly on a loaded 2-core machine."""


@pytest.fixture
def cluster() -> Iterator[tuple[Any, Any]]:
    """A head and one worker node with one CPU each; yields ``(cluster, worker node)``."""
    head_args = {"num_cpus": 1, "include_dashboard": False, "_system_config": FAST_DEATH}
    made = cluster_utils.Cluster(initialize_head=True, head_node_args=head_args)
    try:
        worker = made.add_node(num_cpus=1)
        made.wait_for_nodes()
        yield made, worker
    finally:
        made.shutdown()


def _wait_for(what: Callable[[], bool], proc: subprocess.Popen[str], why: str) -> None:
    deadline = time.monotonic() + LIMIT_S
    while not what():
        if proc.poll() is not None or time.monotonic() > deadline:
            proc.kill()
            out, err = proc.communicate()
            pytest.fail(f"{why}: batch ended or timed out first\n{out}\n{err}")
        time.sleep(0.05)


def test_node_lost_mid_batch_loses_nothing(
    tmp_path: Path, write_drive: Callable[..., Path], cluster: tuple[Any, Any]
) -> None:
    made, worker = cluster
    head_id, worker_id = made.head_node.node_id, worker.node_id
    recs = tmp_path / "recs"
    recs.mkdir()
    for k in range(3):  # long enough (seconds each) to be caught running on the worker node
        write_drive(recs / f"drive_{k}.mcap", seed=k, frames=2000)
    config = tmp_path / "c.json"
    config.write_text('{"frame_format": "png"}')
    root = tmp_path / "out"
    args = [str(recs), "-o", str(root), "--engine", "ray", "--ray-address", made.address]
    args += ["--job", "extract", "--config", str(config)]
    env = dict(os.environ, PYTHONPATH=str(REPO))
    proc = subprocess.Popen(
        [*SLT, "batch", *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env
    )

    def both_busy() -> bool:  # one job per node: one of the two runs on the worker node
        return len(list((root / ".tmp").glob("drive_*.*.*"))) >= 2

    _wait_for(both_busy, proc, "never saw both nodes at work")
    removed = time.monotonic()
    made.remove_node(worker, allow_graceful=False)  # like a power loss: no goodbye to the GCS
    try:
        out, err = proc.communicate(timeout=LIMIT_S)
    except subprocess.TimeoutExpired:
        proc.kill()
        out, err = proc.communicate()
        pytest.fail(f"batch did not finish after the node loss\n{out}\n{err}")
    after_s = time.monotonic() - removed

    # nothing lost: every recording ok, the one on the lost node after a retry on the head
    assert proc.returncode == 0, err
    status = pd.read_parquet(root / "batch_status.parquet").set_index("recording_id")
    assert len(status) == 3
    assert (status["result"] == "ok").all()
    retried = status[status["attempts"] == 2]
    assert len(retried) == 1, status[["attempts", "ray_node", "error"]]
    assert (retried["ray_node"] == head_id).all()
    assert set(status["ray_node"]) <= {head_id, worker_id}
    assert "attempt 1 failed: Ray error: Task failed because the node" in err
    # no half-written folder; the summary covers all three
    folders = [p for p in root.iterdir() if p.is_dir() and p.name != "summary"]
    assert sorted(p.name.split("-")[0] for p in folders) == ["drive_0", "drive_1", "drive_2"]
    assert all((p / MARKER).is_file() for p in folders)
    assert not (root / ".tmp").exists()
    fleet = pd.read_parquet(root / "summary" / "fleet_status.parquet")
    assert (fleet["recordings"].sum(), fleet["ok"].sum()) == (3, 3)
    # stdout holds slt's own lines only; Ray's node-death messages are in the named log
    assert out.startswith("batch: ok 3, partial 0, failed 0, skipped 0 in "), out
    assert all(ln.startswith(("batch:", "status:", "summary:")) for ln in out.splitlines()), out
    log = root / "batch_ray.log"
    assert f"slt: note: Ray's messages (node deaths, worker crashes) are in {log}" in err
    assert worker_id in log.read_text(encoding="utf-8")
    assert "[state-dump]" not in out + err
    print(f"batch ended {after_s:.1f} s after the node loss")  # shown with -s
