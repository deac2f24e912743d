"""Benchmark ``slt camera estimate`` on simulated drives against the simulator's camera.

Run: ``python benchmarks/bench_estimate.py [--seeds 21 22] [--seconds 60] [--fps 2]
[--roll-deg 1.5] [--width 320]``.

For each seed, a ``highway_straight`` (even seeds: ``highway_curves``) drive is simulated with
the camera rolled by ``--roll-deg`` (alternating sign per seed), and the camera's pitch, roll and
height are estimated from 60 frames spread over the drive, once with the true intrinsics and
once with the assumed 60 degree field of view. Roll needs a drive long enough for the lateral
wander in the lane to average out (the simulator's wander has 120-400 m wavelengths), hence the
default of 60 s. Without intrinsics the focal length is measured from the dashes' motion
between consecutive frames, which needs them a few metres apart: use ``--fps 10`` for that
(``--seconds 20 --fps 10 --out estimate_10hz.json``); at 2 Hz the assumed 60 degree field of
view stays. Prints one row per estimate and writes ``benchmarks/results/<--out>``.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import tempfile
from pathlib import Path
from typing import Any

from superlane_tools.commands.camera_estimate import estimate_camera
from superlane_tools.simulation.drive import sim_camera, simulate_drive


def main() -> None:
    """Run the benchmark and write its JSON result."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[21, 22])
    parser.add_argument("--seconds", type=float, default=60.0)
    parser.add_argument("--fps", type=float, default=2.0)
    parser.add_argument("--roll-deg", type=float, default=1.5)
    parser.add_argument("--frames", type=int, default=60)
    parser.add_argument("--width", type=int, default=320)
    parser.add_argument("--out", default="estimate.json", help="file name in benchmarks/results")
    args = parser.parse_args()
    height = args.width * 9 // 16
    truth = sim_camera(args.width, height)
    rows: list[dict[str, Any]] = []
    with tempfile.TemporaryDirectory() as tmp:
        for i, seed in enumerate(args.seeds):
            scenario = "highway_curves" if seed % 2 == 0 else "highway_straight"
            roll = math.radians(args.roll_deg) * (1 if i % 2 == 0 else -1)
            rec = Path(tmp) / f"{scenario}_{seed}.mcap"
            simulate_drive(scenario, args.seconds, seed, "mcap", args.width, height, False, rec,
                           fps=args.fps, camera_roll_rad=roll)  # fmt: skip
            for label, k in (("given", truth.intrinsics), ("assumed_hfov_60", None)):
                result = estimate_camera(rec, intrinsics=k, max_frames=args.frames)
                est = result.estimate
                e = est.extrinsics
                rows.append(
                    {
                        "scenario": scenario,
                        "seed": seed,
                        "intrinsics": label,
                        "pitch_error_deg": round(
                            math.degrees(e.pitch_rad - truth.extrinsics.pitch_rad), 4
                        ),
                        "height_m": round(e.height_m, 4),
                        "height_error_pct": round(
                            100 * (e.height_m / truth.extrinsics.height_m - 1), 2
                        ),
                        "roll_true_deg": round(math.degrees(roll), 4),
                        "roll_error_deg": round(math.degrees(e.roll_rad - roll), 4),
                        "roll_median_sigma_deg": est.summary().get("roll_median_sigma_deg"),
                        "frames_used": est.frames_used,
                        "focal_px": round(result.camera.intrinsics.fx, 2),
                        "intrinsics_source": result.intrinsics_source,
                    }
                )
                print(rows[-1], flush=True)
    out = Path(__file__).parent / "results" / args.out
    load = os.getloadavg()
    out.write_text(
        json.dumps({"args": vars(args), "load": load, "rows": rows}, indent=2) + "\n",
        encoding="utf-8",
    )


if __name__ == "__main__":
    main()
