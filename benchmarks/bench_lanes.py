"""Benchmark the multi-lane fit on TuSimple oracle frames, beside the naive numpy reference.

Single thread (``NUMBA_NUM_THREADS=1``, ``OMP_NUM_THREADS=1``), one process, frames interleaved
so that machine load hits every variant alike:

* ``compiled_cold``: ``fit_frame`` with the numba kernels, loss-curve initialisation (no init);
* ``compiled_sequential``: the same warm-started from the previous frame's fit; TuSimple train
  labels are single frames of different clips, so the previous fit is that of the *same* frame
  rendered again (the best case of ``--sequential``); ``--sim-labels`` adds a real sequence;
* ``reference_cold``: the naive reference in the same process, ``backend="numpy"`` (the same
  algorithm with the pure-numpy cost, scipy's Nelder-Mead and numpy point passes).

Per frame: wall time (``fit_time_s``) and thread CPU time (less sensitive to other jobs on a
shared machine). Also one cost evaluation on 500 points (kernel vs numpy), and the first-call
compile time of the kernels in fresh processes with an empty and a filled numba cache.
Writes ``benchmarks/results/lanes.json``.

Usage: python benchmarks/bench_lanes.py [--frames 100] [--sim-labels DIR --sim-camera YAML]
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("NUMBA_NUM_THREADS", "1")

import argparse
import json
import subprocess
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "pipelines"))

from tusimple_oracle import CLASSES, load_labels, realdata_root, render  # noqa: E402

from superlane_tools.camera import CameraModel, load_camera  # noqa: E402
from superlane_tools.lanes import CostFunction, FitParams, Histogram, LaneFit, fit_frame  # noqa: E402
from superlane_tools.lanes.class_map import mask_points  # noqa: E402

FIRST_CALL = """
import time, numpy as np
from superlane_tools.camera import load_camera
from superlane_tools.lanes import fit_frame
cam = load_camera("tusimple")
u = np.repeat(np.arange(300.0, 900.0), 4)
v = np.tile([700.0, 690.0, 680.0, 670.0], 600)
uv = np.stack([u, v], axis=1)
t0 = time.perf_counter()
fit_frame(uv, None, cam)
print(time.perf_counter() - t0)
"""


def _timed(
    uv: np.ndarray, camera: CameraModel, params: FitParams, init: LaneFit | None
) -> tuple[LaneFit, float, float]:
    c0 = time.thread_time()
    fit = fit_frame(uv, None, camera, params, init=init)
    return fit, fit.fit_time_s, time.thread_time() - c0


def _stats(values: list[float]) -> dict[str, float]:
    ms = np.asarray(values) * 1e3
    return {"median_ms": float(np.median(ms)), "p95_ms": float(np.percentile(ms, 95))}


def first_call_seconds() -> dict[str, float]:
    """Return the first ``fit_frame`` time in fresh processes: empty, then filled numba cache."""
    out = {}
    with tempfile.TemporaryDirectory() as cache:
        env = {**os.environ, "SLT_CACHE_DIR": cache}  # the kernel cache (lanes/kernel_cache.py)
        for name in ("first_call_empty_cache_s", "first_call_filled_cache_s"):
            run = subprocess.run(
                [sys.executable, "-c", FIRST_CALL],
                env=env,
                capture_output=True,
                text=True,
                check=False,
            )
            out[name] = float(run.stdout.split()[-1]) if run.returncode == 0 else float("nan")
    return out


def cost_evaluation_us(frame_uv: np.ndarray, camera: CameraModel) -> dict[str, float]:
    """Return one cost evaluation's time on 500 points, compiled kernel and numpy reference."""
    rays = camera.rays(frame_uv[:: max(1, len(frame_uv) // 500)])
    ok = rays[:, 0] > 1e-6
    iq = -rays[ok, 2] / (camera.extrinsics.height_m * rays[ok, 0])
    r = rays[ok, 1] / rays[ok, 0]
    cost = CostFunction(iq, r, camera.extrinsics.height_m, 200.0, Histogram.symmetric(15, 0.1), 2)
    theta = np.array([0.01, 1e-4, 0.01, 0.0])
    out = {}
    for name, fn in (("kernel_us", cost.__call__), ("numpy_us", cost.reference)):
        fn(theta)
        reps = 2000
        t0 = time.thread_time()
        for _ in range(reps):
            fn(theta)
        out[name] = (time.thread_time() - t0) / reps * 1e6
    out["points"] = float(iq.size)
    return out


def sim_sequence(labels_dir: Path, camera: CameraModel, params: FitParams) -> dict[str, Any]:
    """Time a real sequence (simulator label PNGs) cold and warm-started from the previous frame."""
    import cv2
    from sim_lane_accuracy import classes_yaml

    from superlane_tools.lanes.class_map import parse_classes

    classes = parse_classes(classes_yaml())
    frames = []
    for path in sorted(labels_dir.glob("*.png")):
        mask = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
        if mask is not None:
            frames.append(mask_points(np.asarray(mask), classes).lane_uv)
    cold, seq, cold_cpu, seq_cpu = [], [], [], []
    prev: LaneFit | None = None
    for uv in frames:
        _, wall, cpu = _timed(uv, camera, params, None)
        cold.append(wall)
        cold_cpu.append(cpu)
        fit, wall, cpu = _timed(uv, camera, params, prev)
        seq.append(wall)
        seq_cpu.append(cpu)
        prev = fit if fit.lanes else None
    return {
        "frames": len(frames),
        "cold": _stats(cold),
        "cold_cpu": _stats(cold_cpu),
        "sequential": _stats(seq),
        "sequential_cpu": _stats(seq_cpu),
    }


def main() -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument("--frames", type=int, default=100)
    parser.add_argument("--sim-labels", type=Path, default=None, help="simulator labels/ folder")
    parser.add_argument("--sim-camera", default=None, help="camera profile or YAML of the drive")
    args = parser.parse_args()
    camera = load_camera("tusimple")
    labels = load_labels(realdata_root())
    step = max(1, len(labels) // args.frames)
    records = labels[::step][: args.frames]
    frames = [mask_points(render(r), CLASSES).lane_uv for r in records]
    params = FitParams()
    reference = replace(params, backend="numpy")
    compile_times = first_call_seconds()
    fit_frame(frames[0], None, camera, params)  # load the compiled kernels
    fit_frame(frames[0], None, camera, reference)
    load_before = os.getloadavg()
    wall: dict[str, list[float]] = {"compiled_cold": [], "compiled_sequential": [], "ref": []}
    cpu: dict[str, list[float]] = {k: [] for k in wall}
    evals: dict[str, list[float]] = {k: [] for k in wall}
    for uv in frames:
        fit, w, c = _timed(uv, camera, params, None)
        wall["compiled_cold"].append(w)
        cpu["compiled_cold"].append(c)
        evals["compiled_cold"].append(fit.evaluations)
        warm, w, c = _timed(uv, camera, params, fit)
        wall["compiled_sequential"].append(w)
        cpu["compiled_sequential"].append(c)
        evals["compiled_sequential"].append(warm.evaluations)
        ref, w, c = _timed(uv, camera, reference, None)
        wall["ref"].append(w)
        cpu["ref"].append(c)
        evals["ref"].append(ref.evaluations)
    load_after = os.getloadavg()
    result: dict[str, Any] = {
        "frames": len(frames),
        "lane_pixels_median": float(np.median([len(f) for f in frames])),
        "wall": {
            "compiled_cold": _stats(wall["compiled_cold"]),
            "compiled_sequential": _stats(wall["compiled_sequential"]),
            "reference_cold": _stats(wall["ref"]),
        },
        "thread_cpu": {
            "compiled_cold": _stats(cpu["compiled_cold"]),
            "compiled_sequential": _stats(cpu["compiled_sequential"]),
            "reference_cold": _stats(cpu["ref"]),
        },
        "cost_evaluations_median": {k: float(np.median(v)) for k, v in evals.items()},
        "ratio_reference_to_cold_median_wall": float(
            np.median(wall["ref"]) / np.median(wall["compiled_cold"])
        ),
        "ratio_reference_to_cold_median_cpu": float(
            np.median(cpu["ref"]) / np.median(cpu["compiled_cold"])
        ),
        "cost_evaluation": cost_evaluation_us(frames[0], camera),
        **compile_times,
        "load_average_1min_before_after": [load_before[0], load_after[0]],
        "cpu_count": os.cpu_count(),
    }
    if args.sim_labels is not None:
        sim_cam = load_camera(args.sim_camera or "sim_default")
        result["sim_sequence"] = sim_sequence(args.sim_labels, sim_cam, params)
    out = ROOT / "benchmarks" / "results" / "lanes.json"
    out.write_text(json.dumps(result, indent=2) + "\n", encoding="utf-8")
    print(json.dumps(result, indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
