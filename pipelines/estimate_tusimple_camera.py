"""Estimate the bundled ``tusimple`` camera profile from the TuSimple *train* labels.

Fits a line to every near-straight labelled lane, intersects the lines of each frame (vanishing
point), and takes medians over frames: the vanishing row is the horizon (-> pitch), the vanishing
column the yaw, and the slope step between adjacent lanes fixes the camera height for an assumed
focal length and a 3.75 m mean lane width (see docs/camera.md).

Usage:
    python pipelines/estimate_tusimple_camera.py [LABEL_FILE ...] [--out PATH]

Without label files it reads ``$SLT_REALDATA/tusimple/train_labels/label_data_*.json``
(default ``../shared/data``) and rewrites ``superlane_tools/camera/profiles/tusimple.yaml``.
"""

from __future__ import annotations

import argparse
import os
import sys
from dataclasses import replace
from pathlib import Path

from superlane_tools.camera import CameraModel
from superlane_tools.camera.lane_calibration import (
    LaneCalibration,
    LaneCalibrationParams,
    estimate_camera_from_lanes,
)
from superlane_tools.camera.profiles import camera_to_yaml
from superlane_tools.evaluation import load_jsonl
from superlane_tools.reporting import write_text_atomic

REPO = Path(__file__).resolve().parents[1]
DEFAULT_OUT = REPO / "superlane_tools" / "camera" / "profiles" / "tusimple.yaml"


def default_label_files() -> list[Path]:
    root = Path(os.environ.get("SLT_REALDATA", REPO.parent / "shared" / "data"))
    return sorted((root / "tusimple" / "train_labels").glob("label_data_*.json"))


def estimate(files: list[Path], params: LaneCalibrationParams) -> LaneCalibration:
    for file in files:
        if "test" in file.name.lower():
            raise SystemExit(f"refusing {file}: the camera must come from train labels only")
    frames = [(rec.lanes, rec.h_samples) for file in files for rec in load_jsonl(file)]
    return estimate_camera_from_lanes(frames, params, name="tusimple")


def header(result: LaneCalibration, files: list[Path], params: LaneCalibrationParams) -> str:
    s = result.summary()
    cam = result.camera
    return "\n".join(
        [
            "TuSimple camera, estimated from the TuSimple train labels by",
            "pipelines/estimate_tusimple_camera.py (do not edit by hand; rerun the script).",
            f"labels: {', '.join(f.name for f in files)}",
            f"frames: {int(s['n_frames'])}, with >= 2 near-straight lanes: "
            f"{int(s['n_frames_used'])}",
            f"horizon row px: median {s['horizon_row_median_px']:.1f}, "
            f"MAD {s['horizon_row_mad_px']:.1f}, 5-95% {s['horizon_row_p5_px']:.1f}"
            f"..{s['horizon_row_p95_px']:.1f}",
            f"vanishing column px: median {s['vp_column_median_px']:.1f}, "
            f"MAD {s['vp_column_mad_px']:.1f}",
            f"adjacent-lane slope step du/dv: median {s['slope_step_median']:.4f}, "
            f"MAD {s['slope_step_mad']:.4f} ({int(s['n_slope_steps'])} pairs)",
            f"assumed: focal {params.focal_px:g} px (not observable from lanes), "
            f"lane width {params.lane_width_m:g} m, no roll, no distortion",
            f"result: pitch {cam.extrinsics.pitch_rad:.4f} rad, yaw "
            f"{cam.extrinsics.yaw_rad:.4f} rad, height {cam.extrinsics.height_m:.3f} m",
        ]
    )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("labels", nargs="*", type=Path, help="TuSimple train label files")
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT, help="YAML profile to write")
    parser.add_argument("--focal-px", type=float, default=1000.0, help="assumed focal length")
    parser.add_argument("--lane-width-m", type=float, default=3.75, help="mean lane width")
    args = parser.parse_args(argv)
    files = list(args.labels) or default_label_files()
    if not files:
        print("no TuSimple train label files found (set SLT_REALDATA)", file=sys.stderr)
        return 1
    params = LaneCalibrationParams(focal_px=args.focal_px, lane_width_m=args.lane_width_m)
    result = estimate(files, params)
    text = camera_to_yaml(_rounded(result), comment=header(result, files, params))
    write_text_atomic(args.out, text)
    print(text, end="")
    print(f"wrote {args.out}", file=sys.stderr)
    return 0


def _rounded(result: LaneCalibration) -> CameraModel:
    """Round the extrinsics so the YAML stays readable (0.1 mm, 0.1 mrad)."""
    cam = result.camera
    ext = cam.extrinsics
    return replace(
        cam,
        extrinsics=replace(
            ext,
            height_m=round(ext.height_m, 4),
            pitch_rad=round(ext.pitch_rad, 4),
            yaw_rad=round(ext.yaw_rad, 4),
        ),
    )


if __name__ == "__main__":
    sys.exit(main())
