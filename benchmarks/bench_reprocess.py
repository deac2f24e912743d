"""Benchmark ``reprocess`` end to end at 1280x720 against a decode-only baseline (same run).

Usage: ``python benchmarks/bench_reprocess.py [--frames N] [--repeats R] [--recording PATH]``.
Simulates a ``highway_curves`` drive at 1280x720 (15 Hz) once (or uses ``--recording``), then
times, ``R`` times each:

* baseline: read the recording and decode every JPEG (cv2), nothing else;
* reprocess: the full pipeline with the default config (2 worker threads, plots and
  annotations on), reporting frames/s and the per-stage seconds.

Writes ``benchmarks/results/reprocess.json`` with medians and the ratio. The machine is shared:
wall-clock frames/s depend on the load, so the JSON also holds the load average, the CPU
seconds per frame (process time, all threads) and the CPU milliseconds per frame of every stage
(thread CPU time), which do not; and the 2-core ceiling ``2 / (CPU seconds per frame)``: the
frames/s the run would reach if both cores were idle and perfectly overlapped.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import tempfile
import time
from pathlib import Path

RESULTS = Path(__file__).resolve().parent / "results" / "reprocess.json"


def _decode_only(path: Path) -> tuple[int, float, float]:
    import cv2
    import numpy as np

    from superlane_tools.recording import open_recording

    start, cpu = time.perf_counter(), time.process_time()
    n = 0
    with open_recording(path) as rec:
        for msg in rec.messages(topics=["/camera/image/compressed"]):
            cv2.imdecode(np.frombuffer(bytes(msg.data.data), np.uint8), cv2.IMREAD_COLOR)
            n += 1
    return n, time.perf_counter() - start, time.process_time() - cpu


def main() -> None:
    """Run the benchmark and write the JSON results."""
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--frames", type=int, default=300, help="frames (at 15 Hz)")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--recording", default="", help="use this 1280x720 recording")
    args = parser.parse_args()
    from superlane_tools.commands.reprocess import ReprocessConfig, reprocess
    from superlane_tools.reporting import read_provenance
    from superlane_tools.simulation.drive import simulate_drive

    with tempfile.TemporaryDirectory() as tmp:
        rec = Path(args.recording) if args.recording else Path(tmp) / "bench.mcap"
        if not args.recording:
            simulate_drive("highway_curves", args.frames / 15.0, 0, "mcap", 1280, 720, False, rec)
        base, full, stages, cpu_base, cpu_full, loads = [], [], [], [], [], []
        n, backend, models = 0, "", {}
        for k in range(args.repeats):
            loads.append(os.getloadavg()[0])
            n, secs, cpu = _decode_only(rec)
            base.append(n / secs)
            cpu_base.append(cpu / n)
            result = reprocess(rec, Path(tmp) / f"run{k}", ReprocessConfig())
            resolved = read_provenance(Path(tmp) / f"run{k}" / "frames.parquet")
            backend = resolved["config"]["resolved"]["segmentation_backend"]
            models = resolved.get("models", {})
            cpu_full.append(result.timings["cpu_total"] / max(result.frames, 1))
            full.append(result.frames_per_s)
            stages.append(result.timings)
            print(
                f"repeat {k}: decode-only {base[-1]:.1f} frames/s, "
                f"reprocess {full[-1]:.1f} frames/s, {1e3 * cpu_full[-1]:.1f} CPU ms/frame",
                flush=True,
            )
        loads.append(os.getloadavg()[0])
    med = {key: statistics.median(t[key] for t in stages) for key in stages[0]}
    cpu_stage = {k[4:]: 1e3 * v / n for k, v in med.items() if k.startswith("cpu_")}
    stage_cpu_sum = sum(v for k, v in cpu_stage.items() if k not in ("pass", "post", "total"))
    # Reading, deserialising, row building and Parquet / annotation writes of the pass.
    cpu_stage["pass_other"] = cpu_stage["pass"] - stage_cpu_sum
    out = {
        "frames": n,
        "size": "1280x720",
        "cpus": os.cpu_count(),
        "machine": platform.processor() or platform.machine(),
        "config": "defaults (segmentation backend auto, process_width 640, 2 workers, plots + "
        "annotations)",
        "segmentation_backend": backend,
        "models": models,
        "baseline_decode_fps_median": statistics.median(base),
        "reprocess_fps_median": statistics.median(full),
        "reprocess_fps_all": full,
        "ratio_to_decode": statistics.median(full) / statistics.median(base),
        "load_average_1min": loads,
        "decode_cpu_ms_per_frame_median": 1e3 * statistics.median(cpu_base),
        "reprocess_cpu_ms_per_frame_median": 1e3 * statistics.median(cpu_full),
        "reprocess_fps_if_2_idle_cores": 2.0 / statistics.median(cpu_full),
        "stage_cpu_ms_per_frame": cpu_stage,
        "stage_wall_ms_per_frame": {
            k: 1e3 * v / n for k, v in med.items() if not k.startswith("cpu_")
        },
        "note": "stage_cpu_ms_per_frame: thread CPU time of each image stage, process CPU time "
        "of the pass / post / total (post = tables, plots, report); stage_wall_ms_per_frame: "
        "wall time summed over the worker threads (inflated by the load and the GIL); the "
        "ceiling reprocess_fps_if_2_idle_cores = 2 / (CPU seconds per frame)",
    }
    RESULTS.parent.mkdir(parents=True, exist_ok=True)
    RESULTS.write_text(json.dumps(out, indent=2) + "\n", encoding="utf-8")
    print(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
