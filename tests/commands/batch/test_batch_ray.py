"""The Ray engine against a real local Ray instance (started once; startup costs seconds)."""

from __future__ import annotations

import contextlib
import os
import signal
import threading
import time
from collections.abc import Callable, Iterator
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pandas as pd
import pytest
from typer.testing import CliRunner

from superlane_tools.cli.app import app
from superlane_tools.commands.batch import (
    MARKER,
    BatchParams,
    RayEngine,
    expand_inputs,
    run_batch,
)

pytestmark = pytest.mark.slow  # minutes of subprocesses; run with -m slow

ray = pytest.importorskip("ray")


@pytest.fixture(scope="module")
def local_ray() -> Iterator[None]:
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    yield
    ray.shutdown()


def test_ray_engine_matches_local(
    tmp_path: Path, make_drives: Callable[..., list[Path]], local_ray: None
) -> None:
    make_drives(4, 1)
    entries = expand_inputs([tmp_path / "recs"])
    config = {"frame_format": "none"}
    local = run_batch(entries, BatchParams(tmp_path / "local", "extract", workers=2, config=config))
    params = BatchParams(tmp_path / "ray", "extract", engine="ray", workers=2, config=config)
    report = run_batch(entries, params)
    assert report.engine == "ray"
    assert report.workers == 2
    assert report.counts == local.counts == {"ok": 4, "partial": 0, "failed": 1, "skipped": 0}
    assert report.failures == local.failures
    a = pd.read_parquet(tmp_path / "local" / "batch_status.parquet")
    b = pd.read_parquet(tmp_path / "ray" / "batch_status.parquet")
    assert list(a["recording_id"]) == list(b["recording_id"])
    assert list(a["key"]) == list(b["key"])
    assert set(b["engine"]) == {"ray"}
    for rid in a.loc[a["status"] == "ok", "recording_id"]:
        left = pd.read_parquet(tmp_path / "local" / rid / "can_raw.parquet")
        right = pd.read_parquet(tmp_path / "ray" / rid / "can_raw.parquet")
        pd.testing.assert_frame_equal(left, right)
    # a second run on the joined instance skips everything and runs no task
    again = run_batch([e for e in entries if "drive" in e.path.name], params)
    assert again.counts["skipped"] == 4
    assert ray.is_initialized()  # the engine leaves an instance it did not start running


def test_ray_engine_outside_context_is_a_bug() -> None:
    engine = RayEngine("extract", {})
    with pytest.raises(RuntimeError, match="outside its context"):
        engine.run([], lambda outcome: None)


def _kill_workers_on(tmp_root: Path, prefix: str, stop: threading.Event) -> list[int]:
    """SIGKILL every worker seen building a recording whose id starts with ``prefix``.

    Workers build a recording in ``.tmp/<id>.<host>.<pid>``.

    So the recording takes its worker down every time, like one that crashes a decoder.
    """
    killed: list[int] = []
    while not stop.is_set():
        for folder in tmp_root.glob(f"{prefix}*.*.*"):
            pid = int(folder.name.split(".")[2])
            if pid not in killed:
                with contextlib.suppress(ProcessLookupError):
                    os.kill(pid, signal.SIGKILL)
                killed.append(pid)
        time.sleep(0.001)
    return killed


@pytest.mark.parametrize("engine", ["ray", "local"])
def test_recording_that_kills_its_worker_fails_alone(
    tmp_path: Path, write_drive: Callable[..., Path], engine: str, local_ray: None
) -> None:
    """Through ``slt batch``: every attempt's worker is killed, the others finish, exit 3."""
    recs = tmp_path / "recs"
    recs.mkdir()
    write_drive(recs / "crash.mcap", seed=1, frames=400)
    for k in range(3):
        write_drive(recs / f"fine_{k}.mcap", seed=2 + k, frames=60)
    config = tmp_path / "c.json"
    config.write_text('{"frame_format": "png"}')
    root = tmp_path / "out"
    args = [str(recs), "-o", str(root), "--engine", engine, "--workers", "2", "--retries", "1"]
    args += ["--job", "extract", "--config", str(config)]
    stop = threading.Event()
    with ThreadPoolExecutor(1) as pool:
        killer = pool.submit(_kill_workers_on, root / ".tmp", "crash", stop)
        res = CliRunner().invoke(app, ["batch", *args], catch_exceptions=False)
        stop.set()
        killed = killer.result()
    assert res.exit_code == 3, res.output
    assert "batch: ok 3, partial 0, failed 1, skipped 0" in res.stdout
    (skipped,) = [ln for ln in res.stderr.splitlines() if ln.startswith("slt: skipped:")]
    assert skipped.startswith("slt: skipped: failed recordings (1): crash-")
    assert "died" in skipped
    # one line per attempt that failed, each naming its attempt
    assert res.stderr.count("attempt 1 failed") == res.stderr.count("attempt 2 failed") == 1
    assert "Traceback" not in res.output
    # Ray's own messages (the dead worker) stay off stdout, in the log the note names
    assert all(ln.startswith(("batch:", "status:", "summary:")) for ln in res.stdout.splitlines())
    ray_note = f"Ray's messages (node deaths, worker crashes) are in {root / 'batch_ray.log'}"
    assert (ray_note in res.stderr) == (engine == "ray")
    status = pd.read_parquet(root / "batch_status.parquet").set_index("recording_id")
    (crashed,) = status.index[status["status"] == "failed"]
    assert crashed.startswith("crash-")
    assert status.loc[crashed, "attempts"] == 2
    assert "died" in status.loc[crashed, "error"]
    # every attempt was really killed: at least one distinct worker process per attempt
    assert len(set(killed)) >= 2, killed
    fine = status.drop(index=crashed)
    assert (fine["result"] == "ok").all()
    assert (fine["attempts"] == 1).all()
    assert (fine["ray_node"] != "").all() == (engine == "ray")
    assert (fine["ray_node"] == "").all() == (engine == "local")
    fleet = pd.read_parquet(root / "summary" / "fleet_status.parquet")
    assert (fleet["ok"].sum(), fleet["failed"].sum()) == (3, 1)
    finished = sorted(p.name.split("-")[0] for p in root.iterdir() if (p / MARKER).exists())
    assert finished == ["fine_0", "fine_1", "fine_2"]
    assert not (root / ".tmp").exists()
