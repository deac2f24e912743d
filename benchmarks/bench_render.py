"""Benchmark the drive-simulator renderer at 1280x720 on one core.

Reports, per scenario-like condition, the median wall-clock and CPU milliseconds per frame,
frames per second, the CPU time of each render stage, and the ratio to two baselines measured
in the same run, interleaved frame by frame with the case so both see the same machine load:

* ``cast_and_labels``: the road ray cast plus lane labels only (flat road, no objects, no
  shading) -- the renderer's own floor;
* ``fixed_reference``: a fixed numpy/OpenCV workload that does not depend on the renderer's
  code, to compare runs across changes and machines.

CPU time (``time.thread_time``) is the steadier measure on a shared machine; wall time is what
a user waits for. Writes ``benchmarks/results/render.json``.

Run: ``python benchmarks/bench_render.py [--frames N]``.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import time
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import numpy as np

from superlane_tools.simulation.render import render
from superlane_tools.simulation.render._rays import camera_rays
from superlane_tools.simulation.render.examples import example_scene
from superlane_tools.simulation.render.raycast import cast_road, road_tables
from superlane_tools.simulation.scene import Conditions

CASES = {
    "highway_straight": ("straight", Conditions()),
    "highway_curves": ("curve", Conditions(name="highway_curves")),
    "hills": ("hill", Conditions(name="hills")),
    "night": ("curve", Conditions(name="night", daylight=0.05)),
    "heavy_rain": ("curve", Conditions(name="heavy_rain", rain=1.0, wet=1.0, fog=0.3)),
    "direct_sunlight": ("straight", Conditions(glare=1.0, sun_elevation_deg=5.0)),
    "randomized": ("curve", Conditions(randomize=1.0)),
}
TARGET_MS = 100.0  # the goal: at least 10 frames/s at 1280x720 on one core


def _timed(fn: Callable[[], object]) -> tuple[float, float]:
    """Return (wall ms, CPU ms) of one call."""
    w, c = time.perf_counter(), time.thread_time()
    fn()
    return (time.perf_counter() - w) * 1e3, (time.thread_time() - c) * 1e3


def _reference_work(img: np.ndarray) -> None:
    """A fixed image workload (independent of the renderer's code)."""
    import cv2

    a = img * np.float32(0.9)
    a += np.float32(3.0)
    np.exp(a[..., 0] * np.float32(-0.01), out=a[..., 1])
    cv2.GaussianBlur(a, (0, 0), 2.0)
    np.clip(a, 0.0, 255.0).astype(np.uint8)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--frames", type=int, default=15)
    args = parser.parse_args()
    import cv2

    cv2.setNumThreads(1)
    flat = example_scene("straight", with_objects=False)
    rays = camera_rays(flat.camera)
    ref_img = np.random.default_rng(0).uniform(0, 255, (720, 1280, 3)).astype(np.float32)

    def baseline(i: int) -> None:
        scene = replace(flat, road=replace(flat.road, s_m=flat.road.s_m + 0.5 * i))
        hit = cast_road(rays, road_tables(scene.road))
        labels = np.where(hit.hit, np.uint8(9), np.uint8(1))
        for line in scene.road.lines:
            labels[np.abs(hit.l_m - np.float32(line.offset_m)) < 0.5 * line.width_m] = 13

    results: dict[str, dict[str, object]] = {}
    for name, (kind, cond) in CASES.items():
        scenes = [
            example_scene(kind, conditions=cond, s0_m=1000.0 + 2.0 * i, seed=1) for i in range(3)
        ]
        render(scenes[0])  # warm caches (rays, textures, sky, noise bank)
        baseline(0)
        wall, cpu, base_cpu, base_wall, ref_cpu = [], [], [], [], []
        stages: dict[str, list[float]] = {}
        for i in range(args.frames):
            st: dict[str, float] = {}
            scene = replace(scenes[i % 3], frame_seed=i + 1)
            w, c = _timed(lambda scene=scene, st=st: render(scene, st))  # type: ignore[misc]
            wall.append(w)
            cpu.append(c)
            for k, v in st.items():
                stages.setdefault(k, []).append(v)
            bw, bc = _timed(lambda i=i: baseline(i + 1))  # type: ignore[misc]
            base_wall.append(bw)
            base_cpu.append(bc)
            ref_cpu.append(_timed(lambda: _reference_work(ref_img))[1])
        med = statistics.median
        results[name] = {
            "wall_ms": round(med(wall), 1),
            "cpu_ms": round(med(cpu), 1),
            "fps_wall": round(1000.0 / med(wall), 1),
            "baseline_cast_and_labels_cpu_ms": round(med(base_cpu), 1),
            "baseline_cast_and_labels_wall_ms": round(med(base_wall), 1),
            "fixed_reference_cpu_ms": round(med(ref_cpu), 1),
            "ratio_to_cast_and_labels_cpu": round(med(cpu) / med(base_cpu), 2),
            "ratio_to_fixed_reference_cpu": round(med(cpu) / med(ref_cpu), 2),
            "stage_cpu_ms": {k: round(med(v), 1) for k, v in stages.items()},
        }
        print(name, json.dumps(results[name]), flush=True)
    report = {
        "what": "median ms per 1280x720 frame, one core (cv2.setNumThreads(1))",
        "target_ms": TARGET_MS,
        "frames_per_case": args.frames,
        "machine": f"{platform.processor() or platform.machine()}, {os.cpu_count()} cpus",
        "load_average_at_end": [round(x, 2) for x in os.getloadavg()],
        "cases": results,
    }
    out = Path(__file__).parent / "results" / "render.json"
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(report, indent=2) + "\n", encoding="utf-8")
    print(json.dumps(report, indent=2))


if __name__ == "__main__":
    main()
