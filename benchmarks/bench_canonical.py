"""Cost of the canonical virtual camera: the tables once per drive, the two remaps per frame.

A real TuSimple frame at reprocess's processing size (640x360) and the ``tusimple`` camera;
for each canonical input size: the time to build the forward and inverse tables (once per
drive), and the median per-frame time of the forward remap (frame -> canonical, bilinear) and
of the inverse one (canonical labels -> frame pixels, nearest), OpenCV on one thread.

Usage:
    nice -n 10 python benchmarks/bench_canonical.py [--repeats 50] [--out FILE.json]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import time
from pathlib import Path

import numpy as np


def _coverage() -> list[dict[str, object]]:
    """Share of each bundled profile's frame (at 640 px wide) that the 512x160 camera sees."""
    from superlane_tools.camera import list_profiles, load_camera
    from superlane_tools.camera.canonical import CanonicalCamera, canonical_maps

    rows: list[dict[str, object]] = []
    canonical = CanonicalCamera.for_input(512, 160)
    for name in list_profiles():
        cam = load_camera(name)
        cam = cam.resized(640, round(cam.height * 640 / cam.width))
        maps = canonical_maps(cam, canonical)
        seen = (maps.forward_x >= 0) & (maps.forward_x <= cam.width - 1)
        seen &= (maps.forward_y >= 0) & (maps.forward_y <= cam.height - 1)
        rows.append(
            {
                "profile": name,
                "frame_covered": round(float(maps.covered().mean()), 3),
                "canonical_filled": round(float(seen.mean()), 3),
                "near_range_m": round(canonical.near_range_m(cam.extrinsics.height_m), 2),
            }
        )
        print(rows[-1])
    return rows


def main() -> None:
    import cv2

    from superlane_tools.camera import load_camera
    from superlane_tools.camera.canonical import CanonicalCamera, canonical_maps

    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--realdata", type=Path, default=Path(os.environ.get("SLT_REALDATA", ".")))
    ap.add_argument("--repeats", type=int, default=50)
    ap.add_argument("--out", type=Path, default=Path("benchmarks/results/canonical.json"))
    args = ap.parse_args()
    cv2.setNumThreads(1)
    frame = cv2.imread(str(args.realdata / "tusimple" / "frames" / "0000.png"), cv2.IMREAD_COLOR)
    if frame is None:
        raise SystemExit("slt: error: no TuSimple frame under --realdata/tusimple/frames")
    image = cv2.resize(frame, (640, 360), interpolation=cv2.INTER_AREA)
    camera = load_camera("tusimple").resized(640, 360)
    results = {"load_average_1min": round(os.getloadavg()[0], 2), "frame": "640x360", "rows": []}
    for size in ((512, 160), (512, 288)):
        start = time.perf_counter()
        maps = canonical_maps(camera, CanonicalCamera.for_input(*size))
        build_ms = 1000 * (time.perf_counter() - start)
        labels = np.random.default_rng(0).integers(0, 20, (size[1], size[0])).astype(np.uint8)
        forward, back = [], []
        for _ in range(args.repeats):
            start = time.perf_counter()
            maps.to_canonical(image)
            forward.append(1000 * (time.perf_counter() - start))
            start = time.perf_counter()
            maps.labels_to_source(labels)
            back.append(1000 * (time.perf_counter() - start))
        row = {
            "canonical": f"{size[0]}x{size[1]}",
            "tables_once_ms": round(build_ms, 1),
            "forward_remap_ms": round(statistics.median(forward), 3),
            "back_remap_ms": round(statistics.median(back), 3),
        }
        results["rows"].append(row)
        print(row)
    results["coverage"] = _coverage()
    results["load_average_1min_end"] = round(os.getloadavg()[0], 2)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(results, indent=2) + "\n", encoding="utf-8")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
