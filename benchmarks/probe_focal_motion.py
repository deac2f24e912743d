"""Probe: can the focal length be measured from the dashed markings' motion at a known speed?

Run: ``python benchmarks/probe_focal_motion.py [--drives 21:0 25:0 24:0.05 23:-0.03 26:-0.05]``
(``seed:roll_rad``; even seeds ``highway_curves``, odd ``highway_straight``; 3 s at 10 Hz,
320x180).

Not part of ``slt camera estimate``: a measurement of whether it could be. Without intrinsics
the lane lines give the vanishing point in pixels, so the pitch scales with the assumed focal
length. A dash ``X`` metres ahead lies ``f h / (X cos^2 pitch)`` rows below the horizon, so in
``q = 1 / (rows below the horizon)`` the dash pattern along a line shifts by
``d cos^2(pitch) / (f h)`` between two frames ``d`` metres apart. Per frame the ego lines are
fitted with the assumed 60 degree field of view, the marking pixels along each line are sampled
on a uniform ``q`` grid (rows rotated back by the estimated roll), and the focal length that
best aligns every consecutive pair (summed correlation, both dashed sides) is the estimate.
``d`` comes from the simulator's true positions (a recording would use GNSS or CAN speed).
Prints the focal length found against the true one (250 px at 320 px wide).
"""

from __future__ import annotations

import argparse
import math
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd

from superlane_tools.camera.extrinsics_estimate import (
    estimate_extrinsics,
    frame_lines,
    intrinsics_from_hfov,
)
from superlane_tools.commands.camera_estimate import _LANE_LUT
from superlane_tools.scene.onnx_backend import OnnxSegmentationBackend
from superlane_tools.scene.recording_frames import RecordingFrames
from superlane_tools.simulation.drive import sim_camera, simulate_drive

W, H = 320, 180
Q_GRID = np.linspace(1 / 60, 1 / 6, 400)
F_GRID = np.linspace(100.0, 600.0, 501)


def probe(seed: int, roll_rad: float, tmp: Path) -> tuple[float, int]:
    """Return the focal length (px) found on one simulated drive and the pairs used."""
    scenario = "highway_curves" if seed % 2 == 0 else "highway_straight"
    rec = tmp / f"{scenario}_{seed}.mcap"
    simulate_drive(scenario, 3.0, seed, "mcap", W, H, False, rec, fps=10.0,
                   camera_roll_rad=roll_rad)  # fmt: skip
    gt = pd.read_parquet(tmp / f"{scenario}_{seed}.gt.parquet")
    gt = gt.drop_duplicates("frame_index").sort_values("frame_index")
    pos = gt[["east_m", "north_m"]].to_numpy()
    backend = OnnxSegmentationBackend(threads=1)
    masks = [
        _LANE_LUT[backend.segment(f.image)] for f in RecordingFrames(rec) if f.image is not None
    ]
    k = intrinsics_from_hfov(W, H, 60.0)
    lines = []
    for i, m in enumerate(masks):
        rows, cols = np.nonzero(m)
        lines.append(frame_lines(np.stack([cols, rows], 1).astype(np.float64), k, seed=i))
    est = estimate_extrinsics(lines, k).extrinsics
    c, s = math.cos(est.roll_rad), math.sin(est.roll_rad)
    v_h = k.cy - k.fy * math.tan(est.pitch_rad)
    profiles: list[list[np.ndarray] | None] = []
    for m, fl in zip(masks, lines, strict=True):
        if fl is None:
            profiles.append(None)
            continue
        sides = []
        for a, b in (fl.left, fl.right):
            v = np.arange(H, dtype=np.float64)
            u = np.round((a * (v - k.cy) / k.fy + b) * k.fx + k.cx).astype(int)
            ok = (u >= 1) & (u < W - 1)
            hit = np.zeros(H)
            vi = v.astype(int)
            hit[ok] = m[vi[ok], u[ok]] | m[vi[ok], u[ok] - 1] | m[vi[ok], u[ok] + 1]
            v0 = k.cy + s * (u - k.cx) + c * (v - k.cy)
            keep = ok & (v0 > v_h + 5)
            q = 1.0 / (v0[keep] - v_h)
            order = np.argsort(q)
            sides.append(np.interp(Q_GRID, q[order], hit[keep][order], left=np.nan, right=np.nan))
        profiles.append(sides)
    pairs = []
    for i in range(len(profiles) - 1):
        a_, b_ = profiles[i], profiles[i + 1]
        if a_ is None or b_ is None:
            continue
        d = float(np.linalg.norm(pos[i + 1] - pos[i]))
        pairs += [(d, p0, p1) for p0, p1 in zip(a_, b_, strict=True) if np.nanstd(p0) >= 0.2]
    scale = math.cos(est.pitch_rad) ** 2 / est.height_m
    scores = []
    for f in F_GRID:
        total = 0.0
        for d, p0, p1 in pairs:
            shifted = np.interp(Q_GRID + d * scale / f, Q_GRID, p0, left=np.nan, right=np.nan)
            ok = ~np.isnan(shifted) & ~np.isnan(p1)
            if ok.sum() < 50:
                continue
            x, y = p1[ok] - p1[ok].mean(), shifted[ok] - shifted[ok].mean()
            total += float((x * y).sum() / math.sqrt((x * x).sum() * (y * y).sum() + 1e-9))
        scores.append(total)
    return float(F_GRID[int(np.argmax(scores))]), len(pairs)


def main() -> None:
    """Probe every drive and print the focal length error."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--drives", nargs="+", default=["21:0", "25:0", "24:0.05", "23:-0.03", "26:-0.05"]
    )
    args = parser.parse_args()
    true_f = sim_camera(W, H).intrinsics.fx
    with tempfile.TemporaryDirectory() as tmp:
        for item in args.drives:
            seed, roll = item.split(":")
            f, n = probe(int(seed), float(roll), Path(tmp))
            print(f"seed {seed} roll {roll} rad: f {f:.0f} px (true {true_f:.0f}, "
                  f"{100 * (f / true_f - 1):+.1f} %), {n} frame pairs", flush=True)  # fmt: skip


if __name__ == "__main__":
    main()
