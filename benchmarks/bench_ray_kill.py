"""Seconds until every process of a SIGKILLed ``slt batch --engine ray`` is gone.

Run: ``nice python benchmarks/bench_ray_kill.py [--trials 3]``; writes
``benchmarks/results/ray_kill.json``.

Each trial writes four simulated drives (120 frames each, the fuzz harness's writer), starts a
real ``slt batch --engine ray --workers 2`` (a private local Ray instance), waits until a Ray
worker builds a recording, snapshots every process below the driver (GCS, raylet, agents,
workers, the watchdog), SIGKILLs the driver alone (as the OOM killer would) and times until
none of them runs. Without the watchdog, ``ray::DashboardAgent`` and ``ray::RuntimeEnvAgent``
never exit.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import shutil
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "tests" / "fuzz"))

import fuzzcases as fc  # noqa: E402

from superlane_tools.commands.batch._ray_watchdog import alive, descendants  # noqa: E402

RESULTS = HERE / "results" / "ray_kill.json"


def trial(work: Path, timeout_s: float = 300.0) -> tuple[int, float]:
    """Kill one batch's driver mid-run; return (processes it had started, seconds until gone)."""
    out = work / "out"
    shutil.rmtree(out, ignore_errors=True)  # the killed run's .tmp would look like work
    args = [sys.executable, "-c", "from superlane_tools.cli.app import main; main()", "batch"]
    args += [str(work / "recs"), "--out", str(out), "--job", "extract", "--engine", "ray"]
    args += ["--workers", "2", "--force"]
    proc = subprocess.Popen(args, stderr=subprocess.DEVNULL, start_new_session=True)
    deadline = time.monotonic() + timeout_s
    while not any((out / ".tmp").glob("*")):
        if proc.poll() is not None or time.monotonic() > deadline:
            raise RuntimeError("the batch ended before a worker was seen at work")
        time.sleep(0.02)
    started = descendants(proc.pid)
    if not any(b"raylet" in Path(f"/proc/{p}/cmdline").read_bytes() for p in started):
        raise RuntimeError("no raylet below the driver")
    t0 = time.monotonic()
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    while any(alive(p) for p in started):
        if time.monotonic() - t0 > 60:
            raise RuntimeError(f"processes still running 60 s after the kill: {started}")
        time.sleep(0.02)
    return len(started), time.monotonic() - t0


def main() -> None:
    """Run the trials and write the results."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, default=3)
    parser.add_argument("--out", type=Path, default=RESULTS)
    args = parser.parse_args()
    results = []
    with tempfile.TemporaryDirectory(prefix="slt-raykill-") as tmp:
        work = Path(tmp)
        (work / "recs").mkdir()
        for k in range(4):
            fc.write_drive(work / "recs" / f"d{k}.mcap", frames=120)
        for n in range(args.trials):
            count, seconds = trial(work)
            results.append({"processes": count, "gone_after_s": round(seconds, 3)})
            print(f"trial {n}: {count} processes, all gone {seconds:.2f} s after the SIGKILL")
    load = os.getloadavg()
    result = {
        "command": " ".join(["python", "benchmarks/bench_ray_kill.py", *sys.argv[1:]]),
        "data": "simulated drives (tests/fuzz write_drive), real Ray 2.60 local instance",
        "machine": f"{platform.node()} {platform.machine()} {os.cpu_count()} CPUs (shared)",
        "load_average_1_5_15": [round(v, 2) for v in load],
        "trials": results,
        "median_gone_after_s": statistics.median(r["gone_after_s"] for r in results),
    }
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(result, indent=1) + "\n", encoding="utf-8")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
