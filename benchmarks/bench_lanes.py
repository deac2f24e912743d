"""Benchmark the multi-lane fit on TuSimple oracle frames, beside a naive reference.

Single thread, same process: the optimised ``fit_frame`` (soft-binned bincount cost, batched
loss-curve search, 500-point Nelder-Mead, least-squares refit) and a naive reference (hard-binned
``np.histogram`` cost on all 2000 points, loss curves evaluated one vector at a time, Nelder-Mead
to tight tolerances, no refit). Also the warm-started fit (previous solution of the same frame,
the best case of ``--sequential``). Writes ``benchmarks/results/lanes.json``.

Usage: python benchmarks/bench_lanes.py [--frames 100]
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np
from scipy.optimize import minimize

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "pipelines"))

from tusimple_oracle import CLASSES, load_labels, realdata_root, render  # noqa: E402

from superlane_tools.camera import load_camera  # noqa: E402
from superlane_tools.lanes import FitParams, find_offsets, fit_frame  # noqa: E402
from superlane_tools.lanes.multilane_fit import _Points  # noqa: E402
from superlane_tools.pipeline.lanes_fit import mask_points  # noqa: E402


def naive_fit(lane_uv: np.ndarray, camera, params: FitParams) -> float:
    """Paper-faithful fit without the optimisations; return its time in seconds."""
    t0 = time.perf_counter()
    pts = _Points(camera, lane_uv, params)
    idx = pts.sample(params.max_points, params.seed)
    iq, r = pts.iq[idx], pts.r[idx]
    h = camera.extrinsics.height_m
    edges = np.arange(-params.offset_range_m, params.offset_range_m + 1e-9, params.bin_width_m)

    def cost(theta: np.ndarray) -> float:
        a1, a2, b = theta
        den = iq + b / h
        ok = den >= 1.0 / params.max_range_m
        x = 1.0 / den[ok]
        d = x * (r[ok] - a1 - a2 * x)
        counts, _ = np.histogram(d, bins=edges)
        n_in = counts.sum()
        if n_in == 0:
            return 1e3
        p = counts[counts > 0] / n_in
        return float(-(p * np.log(p)).sum() + params.kappa * iq.size / n_in)

    theta = np.zeros(3)
    grids = [
        np.linspace(-params.heading_bound_rad, params.heading_bound_rad, params.grid_heading),
        np.linspace(-params.curvature_bound, params.curvature_bound, params.grid_curvature) / 2,
        np.linspace(-params.slope_bound, params.slope_bound, params.grid_slope),
    ]
    for k, grid in enumerate(grids):
        vals = []
        for v in grid:
            t = np.zeros(3)
            t[k] = v
            vals.append(cost(t))
        theta[k] = grid[int(np.argmin(vals))]
    res = minimize(
        cost, theta, method="Nelder-Mead", options={"xatol": 1e-5, "fatol": 1e-5, "maxiter": 400}
    )
    a1, a2, b = res.x
    den = iq + b / h
    x = 1.0 / den
    find_offsets(x * (r - a1 - a2 * x), params)
    return time.perf_counter() - t0


def main() -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument("--frames", type=int, default=100)
    args = parser.parse_args()
    camera = load_camera("tusimple")
    labels = load_labels(realdata_root())
    step = max(1, len(labels) // args.frames)
    records = labels[::step][: args.frames]
    frames = [mask_points(render(r), CLASSES).lane_uv for r in records]
    params = FitParams()
    fit_frame(frames[0], None, camera, params)  # warm caches and imports
    cold, warm, naive, iters = [], [], [], []
    for uv in frames:
        fit = fit_frame(uv, None, camera, params)
        cold.append(fit.fit_time_s)
        iters.append(fit.evaluations)
        warm.append(fit_frame(uv, None, camera, params, init=fit).fit_time_s)
        naive.append(naive_fit(uv, camera, params))

    def stats(values: list[float]) -> dict[str, float]:
        ms = np.asarray(values) * 1e3
        return {"median_ms": float(np.median(ms)), "p95_ms": float(np.percentile(ms, 95))}

    result = {
        "frames": len(frames),
        "lane_pixels_median": float(np.median([len(f) for f in frames])),
        "fit_frame_cold": stats(cold),
        "fit_frame_warm": stats(warm),
        "naive_reference": stats(naive),
        "cost_evaluations_median": float(np.median(iters)),
        "speedup_median": float(np.median(naive) / np.median(cold)),
        "load_average_1min": os.getloadavg()[0],
        "cpu_count": os.cpu_count(),
    }
    out = ROOT / "benchmarks" / "results" / "lanes.json"
    out.write_text(json.dumps(result, indent=2) + "\n", encoding="utf-8")
    print(json.dumps(result, indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
