"""Measure the RTK curvature truth through stop-and-go traffic (no rendering, seconds per seed).

Usage::

    python pipelines/standstill_truth.py [--seeds 1,2,3,4] [--duration 120]

For each seed: the ``stop_and_go`` world and its simulated RTK fixes (fixed, 10 Hz, 1 cm
noise), then the reprocess truth (``rtk_truth`` with the default ``[rtk]`` config) at 15 Hz
frame times, compared with the simulator's own path curvature. Prints, per seed, the frames
standing or crawling (< 2 m/s), truth samples among them (must be 0), the largest |curvature|
there, the RMSE against the simulated path curvature and the arc length against the true one.
"""

from __future__ import annotations

import argparse

import numpy as np


def measure(seed: int, duration_s: float) -> str:
    """Return one line of the measurement for ``seed``."""
    from superlane_tools.drive.config import RtkConfig
    from superlane_tools.drive.signals import rtk_truth
    from superlane_tools.simulation.scenarios import SCENARIOS
    from superlane_tools.simulation.sensors import RtkParams, gnss_fixes, rtk_fixes
    from superlane_tools.simulation.world import build_world

    world = build_world(SCENARIOS["stop_and_go"], seed, duration_s)
    fixes = rtk_fixes(world, RtkParams(), 0, np.random.default_rng(seed))
    rows = gnss_fixes(fixes)
    t = np.arange(0.0, duration_s, 1 / 15)
    path = world.path
    speed = np.interp(t, path.t_s, path.speed_mps)
    true_k = np.interp(np.interp(t, path.t_s, path.s_m), world.road.s_m, path.curvature)
    truth = rtk_truth(rows, (t * 1e9).astype(np.int64), RtkConfig())
    k = truth.frame_curvature
    has, slow = np.isfinite(k), speed < 2.0
    worst = float(np.max(np.abs(k[has & slow]))) if (has & slow).any() else float("nan")
    rmse = float(np.sqrt(np.mean((k[has] - true_k[has]) ** 2))) if has.any() else float("nan")
    travelled = float(np.sum(0.5 * (speed[1:] + speed[:-1]) * np.diff(t)))
    return (
        f"seed {seed}: frames {t.size}, standing/crawling {int(slow.sum())}, truth samples "
        f"{int(has.sum())}, of them while < 2 m/s {int((has & slow).sum())} (max |k| {worst:.3g}"
        f" 1/m), RMSE vs simulated path curvature {rmse:.3g} 1/m, arc length "
        f"{np.nanmax(truth.frame_s_m):.1f} m (true {travelled:.1f} m)"
    )


def main() -> None:
    """Parse the arguments and print one line per seed."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", default="1,2,3,4")
    parser.add_argument("--duration", type=float, default=120.0)
    args = parser.parse_args()
    for seed in (int(s) for s in args.seeds.split(",")):
        print(measure(seed, args.duration))


if __name__ == "__main__":
    main()
