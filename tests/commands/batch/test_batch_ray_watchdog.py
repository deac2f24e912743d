"""The watchdog that stops a killed ``slt batch``'s own Ray instance, and nothing else."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from superlane_tools.commands.batch import MARKER
from superlane_tools.commands.batch._ray_watchdog import (
    OWNER_ENV,
    RayWatchdog,
    alive,
    descendants,
)

pytestmark = pytest.mark.skipif(not Path("/proc/self/environ").exists(), reason="needs /proc")

SLEEPER = [sys.executable, "-c", "import time; time.sleep(120)"]


def wait_dead(pids: list[int], timeout_s: float) -> list[int]:
    """Return the ``pids`` still alive after up to ``timeout_s`` seconds."""
    deadline = time.monotonic() + timeout_s
    while (left := [p for p in pids if alive(p)]) and time.monotonic() < deadline:
        time.sleep(0.1)
    return left


@pytest.fixture
def spawn() -> Iterator[Callable[..., subprocess.Popen[bytes]]]:
    """Start sleeper processes; kill whatever is left of them at the end."""
    started: list[subprocess.Popen[bytes]] = []

    def start(*args: str, **kwargs: object) -> subprocess.Popen[bytes]:
        proc = subprocess.Popen([*SLEEPER, *args], **kwargs)  # type: ignore[call-overload]
        started.append(proc)
        return proc  # type: ignore[no-any-return]

    yield start
    for proc in started:
        if proc.poll() is None:
            proc.kill()
        proc.wait()


def test_watchdog_stops_its_instance_and_nothing_else(
    tmp_path: Path, spawn: Callable[..., subprocess.Popen[bytes]]
) -> None:
    session = tmp_path / "session_x"
    (session / "logs").mkdir(parents=True)
    other_env = dict(os.environ, **{OWNER_ENV: "someone-else"})
    # the driver holds its own Ray logs open in the session: it is never swept
    with (session / "logs" / "driver.log").open("wb"), RayWatchdog() as dog:
        with dog.marking():  # like ray.init: the GCS first, with its node id and session
            gcs = spawn("--node-id=abc123", f"--session-dir={session}")
            worker = spawn()
        assert OWNER_ENV not in os.environ
        time.sleep(1.0)  # the watchdog reads the node id and session off the GCS meanwhile
        # started by the raylet: no mark, but the node id, or only a log open in the session
        agent = spawn(env=dict(os.environ, RAY_NODE_ID="abc123"))
        with (session / "logs" / "agent.out").open("wb") as log:  # titled, environment blank
            blank_agent = subprocess.Popen(
                ["bash", "-c", "exec -a ray::DashboardAgent sleep 120"], stdout=log, env={}
            )
            reader = spawn(stdout=log)  # not Ray's, e.g. a user's `tail -f` on the log
        others = [  # another Ray instance of the user, and an unrelated process
            spawn("--node-id=zzz", f"--session-dir={tmp_path / 'session_y'}", env=other_env),
            spawn(env=dict(os.environ, RAY_NODE_ID="zzz")),
            spawn(),
            reader,
        ]
    mine = [gcs, worker, agent, blank_agent]
    for proc in mine:  # the sweep ran before the context returned
        assert proc.poll() is not None or not alive(proc.pid)
    assert all(proc.poll() is None for proc in others)
    blank_agent.wait()


def test_watchdog_stops_the_instance_of_a_sigkilled_driver(tmp_path: Path) -> None:
    pids = tmp_path / "pids"
    driver = subprocess.Popen(
        [
            sys.executable,
            "-c",
            "import subprocess, sys, time\n"
            "from superlane_tools.commands.batch._ray_watchdog import RayWatchdog\n"
            "dog = RayWatchdog().__enter__()\n"
            "with dog.marking():\n"
            f"    procs = [subprocess.Popen({SLEEPER!r}) for _ in range(3)]\n"
            f"open({str(pids)!r}, 'w').write(' '.join(str(p.pid) for p in procs))\n"
            "time.sleep(120)\n",
        ],
        start_new_session=True,
    )
    try:
        deadline = time.monotonic() + 60
        while not pids.exists() or not pids.read_text():
            assert time.monotonic() < deadline
            assert driver.poll() is None
            time.sleep(0.05)
        children = [int(p) for p in pids.read_text().split()]
        assert all(alive(p) for p in children)
        driver.send_signal(signal.SIGKILL)
        driver.wait()
        assert wait_dead(children, 10.0) == []
    finally:
        if driver.poll() is None:
            driver.kill()
            driver.wait()


@pytest.mark.slow  # starts a real local Ray instance twice: about a minute on 2 cores
def test_sigkilled_ray_batch_leaves_no_process_and_reruns_clean(
    tmp_path: Path, write_drive: Callable[..., Path]
) -> None:
    pytest.importorskip("ray")
    recs = tmp_path / "recs"
    recs.mkdir()
    for k in range(4):
        write_drive(recs / f"d{k}.mcap", seed=k, frames=150)
    out = tmp_path / "out"
    args = [sys.executable, "-c", "from superlane_tools.cli.app import main; main()", "batch"]
    args += [str(recs), "--out", str(out), "--job", "extract", "--engine", "ray"]
    args += ["--workers", "2", "--force"]
    env = dict(os.environ, PYTHONPATH=str(Path(__file__).resolve().parents[3]))
    driver = subprocess.Popen(args, env=env, start_new_session=True, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 240
        while not any((out / ".tmp").glob("*")):  # a Ray worker is building a recording
            assert driver.poll() is None, "the batch ended before it could be killed"
            assert time.monotonic() < deadline
            time.sleep(0.05)
        ray_procs = descendants(driver.pid)
        assert any(b"raylet" in Path(f"/proc/{p}/cmdline").read_bytes() for p in ray_procs)
        os.kill(driver.pid, signal.SIGKILL)  # the driver only, as the OOM killer would
        driver.wait()
        survivors = wait_dead(ray_procs, 10.0)
        names = [Path(f"/proc/{p}/cmdline").read_bytes()[:60] for p in survivors]
        assert survivors == [], f"Ray processes outlived the killed batch: {names}"
    finally:
        if driver.poll() is None:
            driver.kill()
            driver.wait()
    rerun = subprocess.run(args, env=env, capture_output=True, timeout=300, check=False)
    assert rerun.returncode == 0, rerun.stderr.decode()[-500:]
    assert sorted(p.name.split("-")[0] for p in out.iterdir() if (p / MARKER).exists()) == [
        f"d{k}" for k in range(4)
    ]
    assert not (out / ".tmp").exists() or not any((out / ".tmp").iterdir())
