"""Benchmark the drive simulator: frames/s of world + render + JPEG + write at 1280x720.

Usage::

    python benchmarks/bench_simulate.py [--duration 4] [--scenario highway_curves]
    python benchmarks/bench_simulate.py --contact-sheet reports/simulator_contact_sheet.jpg

Pins itself to one core (``os.sched_setaffinity``) and one BLAS/OpenCV thread, runs the full
pipeline (``simulate_drive``) into a temporary folder, and writes the median frames/s, the
per-stage split and the ratio of the world stage to the renderer to
``reports/bench_simulate.json``.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import tempfile
import time
from pathlib import Path

REPORTS = Path(__file__).resolve().parents[1] / "reports"


def _one_core() -> None:
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    if hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})
    import cv2

    cv2.setNumThreads(1)


def bench(scenario: str, duration_s: float, repeats: int) -> dict[str, object]:
    from superlane_tools.simulation import simulate_drive

    runs = []
    for r in range(repeats):
        with tempfile.TemporaryDirectory() as tmp:
            t0 = time.perf_counter()
            res = simulate_drive(
                scenario, duration_s, r, "mcap", 1280, 720, False, Path(tmp) / "b.mcap"
            )
            wall = time.perf_counter() - t0
        runs.append((res.frames / wall, {k: v / res.frames for k, v in res.seconds.items()}))
    fps = statistics.median(r[0] for r in runs)
    split = {k: statistics.median(r[1][k] for r in runs) * 1000.0 for k in runs[0][1]}
    return {
        "scenario": scenario,
        "size": "1280x720",
        "frames_per_run": int(duration_s * 15),
        "repeats": repeats,
        "median_frames_per_s": round(fps, 2),
        "ms_per_frame": {k: round(v, 1) for k, v in split.items()},
        "world_to_render_ratio": round(split["world"] / max(split["render"], 1e-9), 3),
    }


def contact_sheet(path: Path, tile: tuple[int, int] = (320, 180)) -> None:
    import cv2
    import numpy as np

    from superlane_tools.simulation.drive import sim_camera
    from superlane_tools.simulation.render import render
    from superlane_tools.simulation.scenarios import SCENARIOS
    from superlane_tools.simulation.world import build_world, frame_world

    camera = sim_camera(1280, 720)
    tiles = []
    for name, spec in SCENARIOS.items():
        world = build_world(spec, 1, 12.0)
        fw = frame_world(world, 8.0, 0, camera, 1)
        img = cv2.resize(render(fw.scene).image_bgr, tile, interpolation=cv2.INTER_AREA)
        cv2.putText(img, name, (6, 16), cv2.FONT_HERSHEY_SIMPLEX, 0.45, (0, 0, 0), 3)
        cv2.putText(img, name, (6, 16), cv2.FONT_HERSHEY_SIMPLEX, 0.45, (255, 255, 255), 1)
        tiles.append(img)
    rows = [np.hstack(tiles[i : i + 4]) for i in range(0, len(tiles), 4)]
    path.parent.mkdir(parents=True, exist_ok=True)
    cv2.imwrite(str(path), np.vstack(rows), [cv2.IMWRITE_JPEG_QUALITY, 90])
    print(f"wrote {path}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--scenario", default="highway_curves")
    parser.add_argument("--duration", type=float, default=4.0)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--contact-sheet", type=Path)
    args = parser.parse_args()
    _one_core()
    if args.contact_sheet:
        contact_sheet(args.contact_sheet)
        return
    result = bench(args.scenario, args.duration, args.repeats)
    REPORTS.mkdir(exist_ok=True)
    (REPORTS / "bench_simulate.json").write_text(json.dumps(result, indent=2) + "\n")
    print(json.dumps(result, indent=2))


if __name__ == "__main__":
    main()
