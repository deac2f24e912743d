"""Benchmark ``slt camera estimate`` on simulated drives against the simulator's camera.

Run: ``python benchmarks/bench_estimate.py [--seeds 21 22] [--seconds 3] [--width 320]``.

For each seed, a ``highway_straight`` (even seeds: ``highway_curves``) drive is simulated and the
camera's pitch and height are estimated from 30 frames, once with the true intrinsics and once
with the assumed 60 degree field of view. Writes ``benchmarks/results/estimate.json``.
"""

from __future__ import annotations

import argparse
import json
import math
import tempfile
from pathlib import Path
from typing import Any

from superlane_tools.commands.camera_estimate import estimate_camera
from superlane_tools.simulation.drive import sim_camera, simulate_drive


def main() -> None:
    """Run the benchmark and write its JSON result."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[21, 22])
    parser.add_argument("--seconds", type=float, default=3.0)
    parser.add_argument("--width", type=int, default=320)
    args = parser.parse_args()
    height = args.width * 9 // 16
    truth = sim_camera(args.width, height)
    rows: list[dict[str, Any]] = []
    with tempfile.TemporaryDirectory() as tmp:
        for seed in args.seeds:
            scenario = "highway_curves" if seed % 2 == 0 else "highway_straight"
            rec = Path(tmp) / f"{scenario}_{seed}.mcap"
            simulate_drive(scenario, args.seconds, seed, "mcap", args.width, height, False, rec,
                           fps=10.0)  # fmt: skip
            for label, k in (("given", truth.intrinsics), ("assumed_hfov_60", None)):
                est = estimate_camera(rec, intrinsics=k, max_frames=30).estimate
                e = est.extrinsics
                rows.append(
                    {
                        "scenario": scenario,
                        "seed": seed,
                        "intrinsics": label,
                        "pitch_error_deg": math.degrees(e.pitch_rad - truth.extrinsics.pitch_rad),
                        "height_m": e.height_m,
                        "height_error_pct": 100 * (e.height_m / truth.extrinsics.height_m - 1),
                        "frames_used": est.frames_used,
                    }
                )
                print(rows[-1])
    out = Path(__file__).parent / "results" / "estimate.json"
    out.write_text(
        json.dumps({"args": vars(args), "rows": rows}, indent=2) + "\n", encoding="utf-8"
    )


if __name__ == "__main__":
    main()
