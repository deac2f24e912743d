"""Benchmark the first ``slt reprocess`` after a fresh install against the second one.

Usage: ``python benchmarks/bench_first_run.py [--repeats R] [--recording PATH]``.

Each repeat starts from an empty lane-fit kernel cache (``SLT_CACHE_DIR`` in a new temporary
folder, as on a machine that never ran ``slt``) and runs ``slt reprocess`` on the sample drive
(``fixtures/sample_drive.mcap``) twice, each in its own process: the first compiles the numba
kernels (and must say so with one ``note:`` line), the second loads them from the cache. The
baseline is the second run, measured in the same repeat. Target: first / second <= 1.3 (wall).

Writes ``benchmarks/results/first_run.json`` with the medians of wall-clock and CPU seconds
(user + system of the child process, all threads) and their ratios. The machine is shared:
wall seconds depend on the load (the load average is recorded), CPU seconds much less.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
RESULTS = Path(__file__).resolve().parent / "results" / "first_run.json"
NOTE = "note: compiling lane-fit kernels (first run only)"
TARGET = 1.3


def _slt() -> str:
    beside = Path(sys.executable).parent / "slt"
    return str(beside) if beside.exists() else shutil.which("slt") or "slt"


def _run(recording: Path, out: Path, cache: Path) -> tuple[float, float, str]:
    """Run ``slt reprocess`` once; return wall seconds, CPU seconds and stderr."""
    env = {**os.environ, "SLT_CACHE_DIR": str(cache)}
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    proc = subprocess.run(
        [_slt(), "reprocess", str(recording), "-o", str(out)],
        env=env,
        capture_output=True,
        text=True,
        check=False,
    )
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode != 0:
        sys.exit(f"slt reprocess failed ({proc.returncode}):\n{proc.stderr}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu, proc.stderr


def main() -> None:
    """Run the benchmark and write the JSON results."""
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--recording", default=str(REPO / "fixtures" / "sample_drive.mcap"))
    args = parser.parse_args()
    recording = Path(args.recording)
    first_wall, first_cpu, second_wall, second_cpu, loads = [], [], [], [], []
    notes_first, notes_second = [], []
    for repeat in range(args.repeats):
        with tempfile.TemporaryDirectory() as tmp:
            cache = Path(tmp) / "cache"
            loads.append(os.getloadavg()[0])
            wall, cpu, err = _run(recording, Path(tmp) / "run1", cache)
            first_wall.append(wall)
            first_cpu.append(cpu)
            notes_first.append(err.count(NOTE))
            wall2, cpu2, err2 = _run(recording, Path(tmp) / "run2", cache)
            second_wall.append(wall2)
            second_cpu.append(cpu2)
            notes_second.append(err2.count(NOTE))
            print(
                f"repeat {repeat + 1}: first {wall:.1f} s wall / {cpu:.1f} s CPU, "
                f"second {wall2:.1f} s wall / {cpu2:.1f} s CPU, load {loads[-1]:.1f}",
                flush=True,
            )
    med = statistics.median
    ratio_wall = med(first_wall) / med(second_wall)
    ratio_cpu = med(first_cpu) / med(second_cpu)
    result = {
        "recording": str(
            recording.relative_to(REPO) if recording.is_relative_to(REPO) else recording
        ),
        "data": "simulated (fixtures/sample_drive.mcap: 16 s highway drive, 240 frames)",
        "command": "python benchmarks/bench_first_run.py " + " ".join(sys.argv[1:]),
        "repeats": args.repeats,
        "cpus": os.cpu_count(),
        "machine": platform.machine(),
        "python": platform.python_version(),
        "first_wall_s": first_wall,
        "second_wall_s": second_wall,
        "first_cpu_s": first_cpu,
        "second_cpu_s": second_cpu,
        "first_wall_s_median": med(first_wall),
        "second_wall_s_median": med(second_wall),
        "first_cpu_s_median": med(first_cpu),
        "second_cpu_s_median": med(second_cpu),
        "ratio_wall_first_to_second": ratio_wall,
        "ratio_cpu_first_to_second": ratio_cpu,
        "target_ratio_wall": TARGET,
        "meets_target": ratio_wall <= TARGET,
        "compile_note_lines_first_run": notes_first,
        "compile_note_lines_second_run": notes_second,
        "load_average_1min": loads,
    }
    RESULTS.parent.mkdir(parents=True, exist_ok=True)
    RESULTS.write_text(json.dumps(result, indent=2) + "\n")
    print(
        f"first run {med(first_wall):.1f} s, second {med(second_wall):.1f} s (wall medians): "
        f"ratio {ratio_wall:.2f} (target <= {TARGET}); CPU ratio {ratio_cpu:.2f} -> {RESULTS}"
    )


if __name__ == "__main__":
    main()
