"""Benchmark the drive-simulator renderer at 1280x720 on one core.

Reports the median milliseconds per frame for a few scenario-like conditions, beside a
baseline measured in the same run (the road ray cast plus labels only: flat road, no objects,
no shading), and writes ``benchmarks/results/render.json``.

Run: ``python benchmarks/bench_render.py [--frames N]``.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import time
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


def _median_ms(fn, frames: int) -> float:  # type: ignore[no-untyped-def]
    fn(0)  # warm caches (rays, textures, sky)
    times = []
    for i in range(frames):
        t = time.perf_counter()
        fn(i + 1)
        times.append((time.perf_counter() - t) * 1e3)
    return statistics.median(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--frames", type=int, default=15)
    args = parser.parse_args()
    import cv2

    cv2.setNumThreads(1)
    flat = example_scene("straight", with_objects=False)
    rays = camera_rays(flat.camera)

    def baseline(i: int) -> None:
        scene = replace(flat, road=replace(flat.road, s_m=flat.road.s_m + 0.5 * i))
        hit = cast_road(rays, road_tables(scene.road))
        labels = np.where(hit.hit, np.uint8(9), np.uint8(1))
        for line in scene.road.lines:
            labels[np.abs(hit.l_m - np.float32(line.offset_m)) < 0.5 * line.width_m] = 13

    results = {"baseline_cast_and_labels": _median_ms(baseline, args.frames)}
    for name, (kind, cond) in CASES.items():
        scenes = [
            example_scene(kind, conditions=cond, s0_m=1000.0 + 2.0 * i, seed=1) for i in range(3)
        ]

        def one(i: int, scenes=scenes) -> None:  # type: ignore[no-untyped-def]
            render(replace(scenes[i % 3], frame_seed=i))

        results[name] = _median_ms(one, args.frames)
    base = results["baseline_cast_and_labels"]
    report = {
        "what": "median ms per 1280x720 frame, one core (cv2.setNumThreads(1))",
        "frames_per_case": args.frames,
        "machine": f"{platform.processor() or platform.machine()}, {os.cpu_count()} cpus",
        "median_ms": {k: round(v, 1) for k, v in results.items()},
        "fps": {k: round(1000.0 / v, 1) for k, v in results.items()},
        "ratio_to_baseline": {k: round(v / base, 2) for k, v in results.items()},
    }
    out = Path(__file__).parent / "results" / "render.json"
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(report, indent=2) + "\n", encoding="utf-8")
    print(json.dumps(report, indent=2))


if __name__ == "__main__":
    main()
