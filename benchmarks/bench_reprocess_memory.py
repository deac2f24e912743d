"""Benchmark the peak memory of ``slt reprocess`` against the drive's length.

Usage: ``python benchmarks/bench_reprocess_memory.py [--short-s 12] [--factor 10]``.

Simulates a short drive and one ``--factor`` times longer with ``slt simulate`` (scenario
highway_curves, same seed and camera: 1280x720 JPEG at 15 Hz, CAN, RTK), then runs
``slt reprocess`` on each in its own process, with default settings (plots and report
included), and reads the peak resident memory of that process (``ru_maxrss`` of a wrapper's
only child). The lane-fit kernels are loaded from the cache (a warm-up run on the short drive
first), so both runs measure the steady state. Target (issue 18): the long drive's peak RSS
within 1.2x the short one's.

Writes ``benchmarks/results/reprocess_memory.json`` with both peaks, their ratio, the run
times and the machine load (``uptime``) before and after.
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _machine import uptime

RESULTS = Path(__file__).resolve().parent / "results" / "reprocess_memory.json"
TARGET = 1.2
_WRAPPER = (
    "import resource, subprocess, sys\n"
    "done = subprocess.run(sys.argv[1:], capture_output=True, text=True)\n"
    "if done.returncode not in (0, 3):\n"
    "    sys.exit(done.stderr)\n"
    "print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)\n"
)
"""Run one command; print its peak RSS (KiB): the wrapper has no other child."""


def _slt() -> str:
    beside = Path(sys.executable).parent / "slt"
    return str(beside) if beside.exists() else shutil.which("slt") or "slt"


def simulate(path: Path, seconds: float) -> None:
    """Write a simulated drive of ``seconds`` with the project's simulator."""
    subprocess.run(
        [_slt(), "simulate", "-s", "highway_curves", "-o", str(path), "--duration", str(seconds)],
        check=True,
        capture_output=True,
    )


def peak_rss_mib(recording: Path, out: Path) -> tuple[float, float]:
    """Run ``slt reprocess`` in a fresh process; return its peak RSS (MiB) and wall seconds."""
    start = time.perf_counter()
    done = subprocess.run(
        [sys.executable, "-c", _WRAPPER, _slt(), "reprocess", str(recording), "-o", str(out)],
        capture_output=True,
        text=True,
        check=False,
    )
    wall = time.perf_counter() - start
    if done.returncode != 0:
        sys.exit(f"slt reprocess failed: {done.stderr or done.stdout}")
    return int(done.stdout.strip().splitlines()[-1]) / 1024.0, wall


def main() -> None:
    """Run the benchmark and write the JSON results."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--short-s", type=float, default=12.0)
    parser.add_argument("--factor", type=float, default=10.0)
    args = parser.parse_args()
    work = Path(tempfile.mkdtemp(prefix="slt-bench-rp-mem-"))
    try:
        short, long = work / "short.mcap", work / "long.mcap"
        simulate(short, args.short_s)
        simulate(long, args.short_s * args.factor)
        uptime_before = uptime()
        peak_rss_mib(short, work / "warm")  # loads (or compiles) the kernels into the cache
        shutil.rmtree(work / "warm")
        rss_short, wall_short = peak_rss_mib(short, work / "out-short")
        shutil.rmtree(work / "out-short")
        rss_long, wall_long = peak_rss_mib(long, work / "out-long")
        uptime_after = uptime()
        result = {
            "command": "python benchmarks/bench_reprocess_memory.py " + " ".join(sys.argv[1:]),
            "data": "simulated (slt simulate, highway_curves, seed 0, 1280x720 JPEG at 15 Hz)",
            "short_s": args.short_s,
            "long_s": args.short_s * args.factor,
            "short_mib": round(short.stat().st_size / 2**20, 1),
            "long_mib": round(long.stat().st_size / 2**20, 1),
            "peak_rss_short_mib": round(rss_short, 1),
            "peak_rss_long_mib": round(rss_long, 1),
            "rss_ratio_long_over_short": round(rss_long / rss_short, 3),
            "target_rss_ratio": TARGET,
            "meets_target": rss_long / rss_short <= TARGET,
            "wall_short_s": round(wall_short, 1),
            "wall_long_s": round(wall_long, 1),
            "uptime": [uptime_before, uptime_after],
        }
    finally:
        shutil.rmtree(work, ignore_errors=True)
    RESULTS.parent.mkdir(parents=True, exist_ok=True)
    RESULTS.write_text(json.dumps(result, indent=2) + "\n")
    print(json.dumps(result, indent=2))


if __name__ == "__main__":
    main()
