"""Benchmark how ``slt reprocess`` and ``slt extract`` scale with resolution, frame rate and length.

Usage: ``python benchmarks/bench_scaling.py [--seconds 8]``.

Simulates one drive per case with ``slt simulate`` (scenario highway_curves, seed 1): the reference
1280x720 at 15 Hz for ``--seconds``; 640x360 and 1920x1080 (resolution); 30 Hz (frame rate);
and 3x the length. Runs ``slt reprocess`` (default settings, kernels already cached by a warm-up
run) and ``slt extract`` (JPEG frames written) on each in a fresh process and records the
child's CPU seconds (user + system, all threads; much less sensitive to the machine's load than
wall time) and wall seconds. CPU seconds per frame and per second of recording, and ratios to
the reference case measured in the same run, are what the sizing in ``docs/performance.md``
uses. Writes ``benchmarks/results/scaling.json`` with ``uptime`` before and after.
"""

from __future__ import annotations

import argparse
import json
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _machine import uptime

RESULTS = Path(__file__).resolve().parent / "results" / "scaling.json"


def _slt() -> str:
    beside = Path(sys.executable).parent / "slt"
    return str(beside) if beside.exists() else shutil.which("slt") or "slt"


def _child(argv: list[str]) -> tuple[float, float]:
    """Run one command; return its CPU seconds and wall seconds (exit 0 or 3 expected)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    done = subprocess.run(argv, capture_output=True, text=True, check=False)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode not in (0, 3):
        sys.exit(f"{' '.join(argv[:2])} failed ({done.returncode}): {done.stderr}")
    cpu = after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime
    return cpu, wall


def main() -> None:
    """Run the benchmark and write the JSON results."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=8.0)
    args = parser.parse_args()
    s = args.seconds
    cases = {
        "reference_1280x720_15hz": (1280, 720, 15.0, s),
        "res_640x360": (640, 360, 15.0, s),
        "res_1920x1080": (1920, 1080, 15.0, s),
        "fps_30": (1280, 720, 30.0, s),
        "length_3x": (1280, 720, 15.0, 3 * s),
    }
    work = Path(tempfile.mkdtemp(prefix="slt-bench-scaling-"))
    results: dict[str, dict[str, float]] = {}
    uptimes = [uptime()]
    try:
        for name, (w, h, fps, seconds) in cases.items():
            rec = work / f"{name}.mcap"
            subprocess.run(
                [_slt(), "simulate", "-s", "highway_curves", "-o", str(rec), "--seed", "1",
                 "--duration", str(seconds), "--width", str(w), "--height", str(h),
                 "--fps", str(fps)],
                check=True, capture_output=True,
            )  # fmt: skip
            if not results:  # load or compile the lane-fit kernels once, outside the timings
                _child([_slt(), "reprocess", str(rec), "-o", str(work / "warm")])
            rp_cpu, rp_wall = _child([_slt(), "reprocess", str(rec), "-o", str(work / "rp")])
            ex_cpu, ex_wall = _child([_slt(), "extract", str(rec), "-o", str(work / "ex")])
            frames = round(seconds * fps)
            results[name] = {
                "width": w,
                "height": h,
                "fps": fps,
                "seconds": seconds,
                "frames": frames,
                "recording_mib": round(rec.stat().st_size / 2**20, 1),
                "reprocess_cpu_s": round(rp_cpu, 2),
                "reprocess_wall_s": round(rp_wall, 2),
                "reprocess_cpu_ms_per_frame": round(1e3 * rp_cpu / frames, 1),
                "extract_cpu_s": round(ex_cpu, 2),
                "extract_wall_s": round(ex_wall, 2),
                "extract_cpu_ms_per_frame": round(1e3 * ex_cpu / frames, 2),
            }
            for folder in ("rp", "ex", "warm"):
                shutil.rmtree(work / folder, ignore_errors=True)
            rec.unlink()
            print(name, results[name], flush=True)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    uptimes.append(uptime())
    ref = results["reference_1280x720_15hz"]
    ratios = {
        name: {
            "reprocess_cpu": round(r["reprocess_cpu_s"] / ref["reprocess_cpu_s"], 3),
            "extract_cpu": round(r["extract_cpu_s"] / ref["extract_cpu_s"], 3),
        }
        for name, r in results.items()
    }
    doc = {
        "command": "python benchmarks/bench_scaling.py " + " ".join(sys.argv[1:]),
        "data": "simulated drives (slt simulate, highway_curves, seed 1)",
        "note": "CPU seconds of the whole command (start-up, imports, model loading included)",
        "cases": results,
        "cpu_ratio_to_reference": ratios,
        "uptime": uptimes,
    }
    RESULTS.parent.mkdir(parents=True, exist_ok=True)
    RESULTS.write_text(json.dumps(doc, indent=2) + "\n")
    print(json.dumps(ratios, indent=2))


if __name__ == "__main__":
    main()
