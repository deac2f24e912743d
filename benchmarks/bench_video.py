"""Benchmark reprocess on an H.264 ``CompressedVideo`` drive against its JPEG twin.

Run: ``python benchmarks/bench_video.py [--seconds 8] [--width 640] [--height 360]
[--repeats 3] [--scenario highway_curves]``.

Both recordings come from ``simulate_drive`` with the same seed, one writing JPEG
``CompressedImage`` frames, the other ``foxglove_msgs/CompressedVideo`` (libx264, CRF 23, a
keyframe every second). One untimed warm-up reprocess loads the models and compiles the
kernels; then the two are reprocessed ``--repeats`` times, interleaved, and the median wall
times give frames per second and the ratio. The lanes of the last runs are compared frame by
frame, and each against the simulator's ground truth (curvature, ego lane width). Writes
``benchmarks/results/video.json``.
"""

from __future__ import annotations

import argparse
import json
import platform
import statistics
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from superlane_tools.commands.reprocess import reprocess
from superlane_tools.drive.config import ReprocessConfig
from superlane_tools.reporting.layout import RunLayout
from superlane_tools.simulation.drive import simulate_drive


def _lane_errors(run: Path, truth: pd.DataFrame) -> dict[str, float]:
    lanes = pd.read_parquet(RunLayout(run).lanes)
    m = lanes.merge(truth[["frame_index", "lane_curvature"]], on="frame_index")
    fitted = m[np.isfinite(m["curvature"])]
    return {
        "frames_fitted": len(fitted),
        "curvature_rmse_per_m": float(
            np.sqrt(np.mean((fitted["curvature"] - fitted["lane_curvature"]) ** 2))
        ),
        "lane_width_median_m": float(np.nanmedian(fitted["lane_width"])),
    }


def _compare(a: Path, b: Path) -> dict[str, float]:
    x = pd.read_parquet(RunLayout(a).lanes)
    y = pd.read_parquet(RunLayout(b).lanes)
    m = x.merge(y, on="frame_index", suffixes=("_jpeg", "_h264"))
    out: dict[str, float] = {}
    for col in ("lane_width", "curvature", "a1", "b"):
        diff = (m[f"{col}_jpeg"] - m[f"{col}_h264"]).abs()
        out[f"{col}_abs_diff_median"] = float(diff.median())
        out[f"{col}_abs_diff_p95"] = float(diff.quantile(0.95))
    return out


def main() -> None:
    """Run the benchmark and write its JSON result."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=8.0)
    parser.add_argument("--width", type=int, default=640)
    parser.add_argument("--height", type=int, default=360)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--scenario", default="highway_curves")
    args = parser.parse_args()
    cfg = ReprocessConfig().with_overrides({"output.plots": False})
    results: dict[str, Any] = {"args": vars(args), "machine": platform.platform()}
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        recs = {}
        for name, video in (("jpeg", None), ("h264", "h264")):
            recs[name] = root / f"{name}.mcap"
            simulate_drive(
                args.scenario, args.seconds, 3, "mcap", args.width, args.height, False,
                recs[name], video=video,
            )  # fmt: skip
            results[f"{name}_bytes"] = recs[name].stat().st_size
        reprocess(recs["jpeg"], root / "warmup", cfg)
        walls: dict[str, list[float]] = {"jpeg": [], "h264": []}
        frames = 0
        for i in range(args.repeats):
            for name in ("jpeg", "h264") if i % 2 == 0 else ("h264", "jpeg"):
                t0 = time.perf_counter()
                frames = reprocess(recs[name], root / f"run_{name}_{i}", cfg).frames
                walls[name].append(time.perf_counter() - t0)
        last = args.repeats - 1
        truth = pd.read_parquet(root / "jpeg.gt.parquet")
        for name, wall in walls.items():
            med = statistics.median(wall)
            results[name] = {
                "wall_s": wall,
                "median_s": med,
                "fps": frames / med,
                **_lane_errors(root / f"run_{name}_{last}", truth),
            }
        results["h264_over_jpeg_time"] = results["h264"]["median_s"] / results["jpeg"]["median_s"]
        results["lanes_jpeg_vs_h264"] = _compare(
            root / f"run_jpeg_{last}", root / f"run_h264_{last}"
        )
    out = Path(__file__).parent / "results" / "video.json"
    out.write_text(json.dumps(results, indent=2) + "\n", encoding="utf-8")
    print(json.dumps(results, indent=2))


if __name__ == "__main__":
    main()
