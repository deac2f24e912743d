"""Benchmark the classical extractor and the Hough baseline at 1280x720 on real frames.

Reports the median milliseconds per frame over the real TuSimple frames beside a trivial
baseline (``cv2.cvtColor`` + ``GaussianBlur``) measured in the same run, and the extractor's
lane-marking recall / precision against the TuSimple labels. Writes
``benchmarks/results/classical.json``.

Usage: ``python benchmarks/bench_classical.py [--data ../shared/data] [--repeat 3]``
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import time
from collections.abc import Callable
from pathlib import Path

import cv2
import numpy as np

from superlane_tools.camera.profiles import load_camera
from superlane_tools.corridor import detect_ego_lane
from superlane_tools.hierarchy import leaf_ids_under
from superlane_tools.reporting import write_text_atomic
from superlane_tools.reporting.layout import TUSIMPLE_LABELS_FILE
from superlane_tools.scene import ClassicalExtractor

ROOT = Path(__file__).resolve().parents[1]
MARKING_IDS = np.array(leaf_ids_under("lane_marking"))


def _median_ms(fn: Callable[[np.ndarray], object], frames: list[np.ndarray], repeat: int) -> float:
    fn(frames[0])  # warm-up (lazy imports, allocator)
    times = []
    for _ in range(repeat):
        for frame in frames:
            start = time.perf_counter()
            fn(frame)
            times.append((time.perf_counter() - start) * 1000.0)
    return float(np.median(times))


def _trivial(frame: np.ndarray) -> object:
    return cv2.GaussianBlur(cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY), (5, 5), 0)


def _scores(folder: Path, extractor: ClassicalExtractor) -> dict[str, float]:
    hits = points = near_px = pred_px = 0
    for line in (folder / TUSIMPLE_LABELS_FILE).read_text().splitlines():
        lab = json.loads(line)
        seg = extractor.segment(cv2.imread(str(folder / lab["raw_file"])))
        marks = np.isin(seg, MARKING_IDS)
        dist = cv2.distanceTransform((~marks).astype(np.uint8), cv2.DIST_L2, 5)
        lines = np.zeros(seg.shape, np.uint8)
        for lane in lab["lanes"]:
            pts = [
                (x, y) for x, y in zip(lane, lab["h_samples"], strict=True) if 0 <= x < seg.shape[1]
            ]
            points += len(pts)
            hits += sum(int(dist[y, x] <= 3.0) for x, y in pts)
            if len(pts) > 1:
                cv2.polylines(lines, [np.array(pts, np.int32)], False, 1, 1)
        near = cv2.distanceTransform((1 - lines).astype(np.uint8), cv2.DIST_L2, 5)
        top = min(lab["h_samples"])
        near_px += int((near[top:][marks[top:]] <= 10).sum())
        pred_px += int(marks[top:].sum())
    return {
        "marking_point_recall_3px": hits / points,
        "marking_pixel_precision_10px": near_px / pred_px,
    }


def main() -> None:
    """Run the benchmark and write the JSON result."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--data",
        type=Path,
        default=Path(os.environ.get("SLT_REALDATA", ROOT.parent / "shared" / "data")),
    )
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument(
        "--out", type=Path, default=ROOT / "benchmarks" / "results" / "classical.json"
    )
    args = parser.parse_args()
    folder = args.data / "tusimple" / "frames"
    frames = [cv2.imread(str(p)) for p in sorted(folder.glob("*.png"))]
    cam = load_camera("tusimple")
    extractor = ClassicalExtractor(camera=cam)
    trivial = _median_ms(_trivial, frames, args.repeat)
    classical = _median_ms(extractor.segment, frames, args.repeat)
    hough = _median_ms(lambda f: detect_ego_lane(f, cam), frames, args.repeat)
    result = {
        "frames": len(frames),
        "size": "1280x720",
        "repeat": args.repeat,
        "machine": f"{platform.machine()} {os.cpu_count()} cpus",
        "opencv_threads": cv2.getNumThreads(),
        "ms_per_frame_median": {
            "trivial_cvtcolor_blur": trivial,
            "classical_extractor": classical,
            "hough_baseline": hough,
        },
        "ratio_to_trivial": {
            "classical_extractor": classical / trivial,
            "hough_baseline": hough / trivial,
        },
        "real_frame_scores": _scores(folder, extractor),
    }
    write_text_atomic(args.out, json.dumps(result, indent=2) + "\n")
    print(json.dumps(result, indent=2))


if __name__ == "__main__":
    main()
