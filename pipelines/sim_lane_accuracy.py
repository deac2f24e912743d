"""Lane-fit accuracy per simulator scenario: heading, curvature, slope and ego offsets vs truth.

For each scenario: ``slt simulate --labels`` writes a short drive with leaf-id label PNGs and
the ground truth ``<stem>.gt.parquet``; a ``classes.yaml`` built from
``superlane_tools.hierarchy.leaf_ids_under`` maps them to the fit's classes; ``slt lanes fit
--sequential`` fits every label PNG with the simulator's camera (``sim_default``, resized by the
fit to the drive's size); each frame is matched to its truth row by index and compared:

* heading ``a1`` vs ``lane_heading_rad`` (rad), curvature ``2 a2`` vs ``lane_curvature`` (1/m),
  slope ``b`` vs ``road_slope`` (both fitted by the simulator over 5-60 m);
* the ego lines' offsets (fit ``offsets[ego_left]``, ``offsets[ego_right]``) vs
  ``line_offset_m[ego_left_line]``, ``line_offset_m[ego_right_line]`` (m);
* the ego lines' lateral position 20 m ahead (each line's own ``lane_a1``, ``lane_a2`` vs the
  truth's shared polynomial), which does not depend on how a quadratic splits a clothoid into
  heading and curvature over a given range.

The labels are the simulator's exact classes (an oracle segmentation): what remains is the
geometry of the fit. Writes a markdown table (RMSE and median absolute error per scenario) with
the exact commands.

Usage:
    python pipelines/sim_lane_accuracy.py [--work DIR] [--duration 8] [--width 640]
        [--height 360] [--fps 10] [--scenarios a,b,...] [--report reports/sim_lane_accuracy.md]
        [--json out.json] [--reuse]
"""

from __future__ import annotations

import argparse
import json
import math
import shlex
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow.parquet as pq
import yaml

from superlane_tools.hierarchy import leaf_ids_under
from superlane_tools.lanes import MARKING_CODES
from superlane_tools.reporting import read_provenance

SCENARIOS = (
    "highway_straight",
    "highway_curves",
    "hills",
    "merge_split",
    "urban",
    "faded_lines",
)
CAMERA = "sim_default"
METRICS = ("heading_rad", "curvature_1pm", "slope", "ego_left_m", "ego_right_m", "ego_y20_m")
AHEAD_M = 20.0
"""Forward distance of the range-independent check: ego lines' lateral position there, metres."""


def classes_yaml() -> dict[str, list[int]]:
    """Return the class map of the simulator's leaf-id labels (road and marking nodes)."""
    out = {"road": list(leaf_ids_under("road"))}
    for node, _ in MARKING_CODES:
        ids = list(leaf_ids_under(node)) if node != "lane_marking" else []
        if ids:
            out[node] = ids
    return out


def _run(cmd: list[str], log: list[str]) -> None:
    log.append(shlex.join(cmd))
    done = subprocess.run(cmd, capture_output=True, text=True, check=False)
    if done.returncode != 0:
        raise SystemExit(f"command failed ({done.returncode}): {shlex.join(cmd)}\n{done.stderr}")


def run_scenario(
    scenario: str, work: Path, args: argparse.Namespace, log: list[str]
) -> tuple[Path, Path]:
    """Simulate (unless reused) and fit one scenario; return the truth and fit Parquet paths."""
    stem = work / scenario
    gt = work / f"{scenario}.gt.parquet"
    labels = work / f"{scenario}_labels" / "labels"
    if args.reuse and gt.exists() and labels.is_dir():
        # The drive's own provenance says which command wrote it.
        log.append(str(read_provenance(gt).get("command", f"(reused {gt})")))
    else:
        _run(
            [
                "slt", "simulate", "--scenario", scenario, "--duration", str(args.duration),
                "--seed", str(args.seed), "--width", str(args.width), "--height",
                str(args.height), "--fps", str(args.fps), "--labels", "--out",
                f"{stem}.mcap", "--overwrite",
            ],
            log,
        )  # fmt: skip
    classes = work / f"{scenario}.classes.yaml"
    classes.write_text(yaml.safe_dump(classes_yaml(), sort_keys=False), encoding="utf-8")
    lanes = work / f"{scenario}.lanes.parquet"
    _run(
        [
            "slt", "lanes", "fit", str(labels), "--camera", CAMERA, "--classes", str(classes),
            "--out", str(lanes), "--sequential", "--overwrite",
        ],
        log,
    )  # fmt: skip
    return gt, lanes


def _ego(offsets: Any, index: int) -> float:
    return float(offsets[index]) if 0 <= index < len(offsets) else math.nan


def _ahead(fit: dict[str, Any], index: int) -> float:
    if not 0 <= index < len(fit["offsets"]):
        return math.nan
    x = AHEAD_M
    return float(fit["offsets"][index] + x * (fit["lane_a1"][index] + x * fit["lane_a2"][index]))


def _ahead_truth(truth: dict[str, Any], offset_m: float) -> float:
    x = AHEAD_M
    return offset_m + x * (
        float(truth["lane_heading_rad"]) + x * 0.5 * float(truth["lane_curvature"])
    )


def compare(gt_path: Path, lanes_path: Path) -> dict[str, Any]:
    """Return per-metric errors (fit minus truth) and coverage of one scenario's drive."""
    gt = pq.read_table(gt_path).to_pylist()
    fits = pq.read_table(lanes_path).to_pylist()
    by_index = {int(Path(row["name"]).stem): row for row in fits}
    errors: dict[str, list[float]] = {m: [] for m in METRICS}
    n_fitted = 0
    for truth in gt:
        fit = by_index.get(int(truth["frame_index"]))
        if fit is None or fit["reason"] not in ("",):
            continue
        n_fitted += 1
        errors["heading_rad"].append(fit["a1"] - truth["lane_heading_rad"])
        errors["curvature_1pm"].append(fit["curvature"] - truth["lane_curvature"])
        errors["slope"].append(fit["b"] - truth["road_slope"])
        for side, key, gt_key in (
            ("ego_left_m", "ego_left", "ego_left_line"),
            ("ego_right_m", "ego_right", "ego_right_line"),
        ):
            true = _ego(truth["line_offset_m"], int(truth[gt_key]))
            got = _ego(fit["offsets"], int(fit[key]))
            if math.isfinite(true):
                errors[side].append(got - true)  # NaN when the fit has no ego line there
                errors["ego_y20_m"].append(_ahead(fit, int(fit[key])) - _ahead_truth(truth, true))
    out: dict[str, Any] = {"frames": len(gt), "fitted": n_fitted}
    for name, values in errors.items():
        v = np.asarray(values, dtype=np.float64)
        ok = v[np.isfinite(v)]
        out[name] = {
            "n": int(v.size),
            "found": int(ok.size),
            "rmse": float(np.sqrt(np.mean(ok**2))) if ok.size else math.nan,
            "median_abs": float(np.median(np.abs(ok))) if ok.size else math.nan,
            "mean": float(np.mean(ok)) if ok.size else math.nan,
        }
    return out


def report(results: dict[str, dict[str, Any]], commands: list[str], argv: list[str]) -> str:
    """Return the markdown report."""
    head = (
        "| scenario | fitted | heading RMSE / med (mrad) | curvature RMSE / med (1e-4 1/m) "
        "| slope RMSE / med (%) | ego left RMSE / med (m), found | ego right RMSE / med (m), "
        "found | ego lines at 20 m RMSE / med (m) |"
    )
    rows = [head, "|---|---|---|---|---|---|---|---|"]
    scale = {"heading_rad": 1e3, "curvature_1pm": 1e4, "slope": 1e2}

    def cell(res: dict[str, Any], key: str, unit: float = 1.0, digits: int = 2) -> str:
        m = res[key]
        text = f"{m['rmse'] * unit:.{digits}f} / {m['median_abs'] * unit:.{digits}f}"
        return text if key in scale else f"{text}, {m['found']}/{m['n']}"

    for name, res in results.items():
        rows.append(
            f"| {name} | {res['fitted']}/{res['frames']} | "
            f"{cell(res, 'heading_rad', 1e3)} | {cell(res, 'curvature_1pm', 1e4)} | "
            f"{cell(res, 'slope', 1e2)} | {cell(res, 'ego_left_m')} | "
            f"{cell(res, 'ego_right_m')} | {cell(res, 'ego_y20_m')} |"
        )
    cmd = shlex.join(["python", "pipelines/sim_lane_accuracy.py", *argv[1:]])
    return "\n".join(
        [
            "# Lane-fit accuracy on the simulator's scenarios",
            "",
            f"Command (repository root, venv active): `{cmd}`",
            "",
            "Each scenario is simulated with ground truth and leaf-id label PNGs, the labels are "
            "fitted with `slt lanes fit --sequential` and the `sim_default` camera (resized to "
            "the drive), and every fitted frame is compared with the truth row of the same "
            "index: heading `a1`, curvature `2 a2` and slope `b` against the simulator's "
            "`lane_heading_rad`, `lane_curvature`, `road_slope` (fitted over 5-60 m), and the "
            "ego lines' offsets. RMSE / median absolute error; `fitted` = frames with at least "
            "two lines (`reason` empty); `found` = frames where the fit has the ego line that "
            "the truth has on that side.",
            "",
            *rows,
            "",
            "Reading the table (what the runs of 2026-11 showed; signs of heading, curvature, "
            "slope and offsets agree with the truth in every scenario):",
            "",
            "* Heading and curvature depend on the range a quadratic is fitted over: on a "
            "clothoid (curvature changing along the road) the truth's 5-60 m fit and the "
            "image-weighted fit over everything visible split the same curve differently into "
            "`a1` and `a2`. The ego lines' lateral position 20 m ahead does not depend on that "
            "split and stays at a few centimetres (median) where heading errors reach 10 mrad.",
            "* `hills`: the linear road model `z = b x` under-reads the slope of crests and sags "
            "(a vertical curve) and the lines end at the crest; a quadratic road profile is the "
            "natural next model.",
            "* `urban`: the outliers (RMSE far above the median) are intersection frames, where "
            "the ego lines are not visible and the cross street's markings are fitted as lines; "
            "`merge_split`: outliers in the taper, where a line leaves the parallel model.",
            "",
            "Commands run (with `--reuse`, drives already in `--work` are re-fitted and their "
            "`slt simulate` command is the one recorded in their provenance):",
            "",
            "```",
            *commands,
            "```",
            "",
        ]
    )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--work", type=Path, default=None, help="folder for drives (temp dir)")
    parser.add_argument("--duration", type=float, default=8.0, help="drive length, seconds")
    parser.add_argument("--width", type=int, default=640)
    parser.add_argument("--height", type=int, default=360)
    parser.add_argument("--fps", type=float, default=10.0)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--scenarios", default=",".join(SCENARIOS))
    parser.add_argument("--reuse", action="store_true", help="reuse drives already in --work")
    parser.add_argument("--report", type=Path, default=None)
    parser.add_argument("--json", type=Path, default=None)
    args = parser.parse_args(argv)
    argv_all = [sys.argv[0], *(argv if argv is not None else sys.argv[1:])]
    with tempfile.TemporaryDirectory() as tmp:
        work = args.work or Path(tmp)
        work.mkdir(parents=True, exist_ok=True)
        results: dict[str, dict[str, Any]] = {}
        commands: list[str] = []
        for scenario in args.scenarios.split(","):
            gt, lanes = run_scenario(scenario, work, args, commands)
            results[scenario] = compare(gt, lanes)
            res = results[scenario]
            print(
                f"{scenario}: fitted {res['fitted']}/{res['frames']}, "
                + ", ".join(
                    f"{m} rmse {res[m]['rmse']:.4g} med {res[m]['median_abs']:.4g}" for m in METRICS
                ),
                flush=True,
            )
    if args.json:
        args.json.write_text(json.dumps(results, indent=2) + "\n", encoding="utf-8")
    if args.report:
        args.report.write_text(report(results, commands, argv_all), encoding="utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
