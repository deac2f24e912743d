"""Measure every set of the default rule for segmentation models in one run, and judge them.

``superlane_tools.scene.default_rule`` makes a model the default only when, in one run of the
evaluation chain, it is no worse than the best other model on each set and fast enough. This
script is that run:

* real sets (``pipelines/real_frames_eval.py``, never trained on): TuSimple dev LaneEval
  (without the run-time gate), KITTI ``um_000000`` ego-lane F, CULane night and held-out day
  clip F1@50, CamVid val level-2 mIoU;
* the simulated held-out set (seed 99, 40 frames, 640x360; simulated): lane-marking IoU and
  level 1-4 mIoU;
* simulated held-out drives (``slt simulate -s {highway_curves,hills,urban} --duration 10
  --seed {101,102,103} --width 960 --height 540``; simulated, never trained on), each
  reprocessed with ``--model MODEL``: SUPER availability and ``super_path`` RMSE, pooled over
  the three drives;
* the demo drive (``fixtures/sample_drive.mcap``, simulated): the same two;
* onnxruntime milliseconds per frame, one thread, beside ``super_seg_v4`` in the same run.

Usage::

    python pipelines/release_eval.py super_seg_v4 runs/v7/super_seg_v7.onnx \\
        [--data ../shared/data] [--work runs/release] [--json out.json] [--update-cards]

Prints one JSON line of sets per model, then each model's verdict against the others.
``--update-cards`` writes each model's numbers into its card (``metrics.release``), where the
rule reads them.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import shlex
import subprocess
import sys
from dataclasses import replace
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parents[1]
SLT = str(Path(sys.executable).with_name("slt"))
DRIVES = (("highway_curves", 101), ("hills", 102), ("urban", 103))
DEMO = REPO / "fixtures" / "sample_drive.mcap"
SETS = (
    "tusimple_dev_laneeval",
    "kitti_um_000000_f",
    "culane_night_f1",
    "culane_day_f1",
    "camvid_val_miou_l2",
    "sim_heldout_lane_marking_iou",
    *(f"sim_heldout_miou_level{k}" for k in (1, 2, 3, 4)),
    "sim_drives_super_availability",
    "sim_drives_super_path_rmse",
    "demo_super_availability",
    "demo_super_path_rmse",
)
"""Every set the rule compares: the shipped cards' ``release`` sets (a test keeps them equal)."""


def _run(args: list[str]) -> None:
    subprocess.run(args, check=True, capture_output=True, text=True)


def _rounded(name: str, value: float) -> float:
    return round(float(value), 7 if name.endswith("_rmse") else 4)


def _name(model: str) -> str:
    return Path(model).stem if model.endswith(".onnx") else model


def real_sets(models: list[str], data: Path, work: Path) -> dict[str, dict[str, float]]:
    """Run the real-frame chains for every model at once; return each model's five numbers."""
    out = work / "real.json"
    backends = ",".join(f"onnx={m}" for m in models)
    _run([
        sys.executable, str(REPO / "pipelines" / "real_frames_eval.py"), "--data", str(data),
        "--work", str(work / "real"), "--backends", backends, "--json", str(out),
        "--report", str(work / "real.md"),
    ])  # fmt: skip
    found = json.loads(out.read_text(encoding="utf-8"))
    sets = {}
    for model in models:
        r = found[f"onnx_{_name(model)}"]
        sets[_name(model)] = {
            "tusimple_dev_laneeval": r["tusimple"]["ungated"]["accuracy"],
            "kitti_um_000000_f": r["kitti"]["score"]["f_measure"],
            "culane_night_f1": r["culane"]["score"]["all"]["f1_50"],
            "culane_day_f1": r["culane_day"]["score"]["all"]["f1_50"],
            "camvid_val_miou_l2": r["camvid"]["miou_l2"],
        }
    return sets


def sim_heldout(model: str, work: Path) -> dict[str, float]:
    """Score the simulated held-out set (made once): lane-marking IoU and level 1-4 mIoU."""
    from superlane_tools.reporting.layout import DatasetLayout
    from superlane_tools.training.evaluate import evaluate_segmentation_on_dataset

    folder = work / "sim_heldout_s99_40_640x360"
    if not DatasetLayout(folder).index.is_file():
        _run([
            SLT, "simulate", "dataset", "--out", str(folder), "--frames", "40", "--seed", "99",
            "--width", "640", "--height", "360", "--overwrite",
        ])  # fmt: skip
    r = evaluate_segmentation_on_dataset(model, folder)
    return {
        "sim_heldout_lane_marking_iou": r["lane_marking_iou"],
        **{f"sim_heldout_miou_level{k}": r[f"miou_level{k}"] for k in (1, 2, 3, 4)},
    }


def drive_numbers(model: str, recordings: list[Path], runs: Path) -> tuple[float, float]:
    """Reprocess the recordings with ``model``; return pooled SUPER availability and RMSE."""
    import pandas as pd

    from superlane_tools.reporting.layout import RunLayout

    available, squares, n = [], 0.0, 0
    for recording in recordings:
        out = runs / _name(model) / recording.stem
        _run([
            SLT, "reprocess", str(recording), "--model", model, "-o", str(out), "--no-plots",
            "--overwrite",
        ])  # fmt: skip
        layout = RunLayout(out)
        frames = pd.read_parquet(layout.availability_frames)
        available += list(frames.loc[frames["method"] == "super", "available"])
        summary = pd.read_parquet(layout.curvature_summary)
        row = summary[(summary["scope"] == "overall") & (summary["source"] == "super_path")]
        squares += float(row["rmse"].iloc[0]) ** 2 * int(row["n"].iloc[0])
        n += int(row["n"].iloc[0])
    return sum(available) / len(available), math.sqrt(squares / n) if n else math.inf


def main(argv: list[str] | None = None) -> int:
    """Measure, print and judge; return 0 (1 when a chain fails)."""
    from superlane_tools.scene.default_rule import RELEASE, SPEED_REFERENCE, judge
    from superlane_tools.training.evaluate import time_model

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("models", nargs="+")
    default = os.environ.get("SLT_REALDATA", str(REPO.parent / "shared" / "data"))
    ap.add_argument("--data", type=Path, default=Path(default))
    ap.add_argument("--work", type=Path, default=Path("runs/release"))
    ap.add_argument("--json", type=Path, default=None)
    ap.add_argument("--update-cards", action="store_true")
    args = ap.parse_args(argv)
    work: Path = args.work
    work.mkdir(parents=True, exist_ok=True)
    models: list[str] = list(args.models)
    uptime = subprocess.run(["uptime"], check=False, capture_output=True, text=True).stdout.strip()

    sets = real_sets(models, args.data, work)
    drives = []
    for scenario, seed in DRIVES:
        path = work / "drives" / f"{scenario}_{seed}.mcap"
        if not path.is_file():
            _run([
                SLT, "simulate", "-s", scenario, "--duration", "10", "--seed", str(seed),
                "--width", "960", "--height", "540", "-o", str(path), "--overwrite",
            ])  # fmt: skip
        drives.append(path)
    reference_ms = time_model(SPEED_REFERENCE, "segmentation", threads=1)["median_ms"]
    releases: dict[str, dict[str, Any]] = {}
    for model in models:
        name = _name(model)
        sets[name].update(sim_heldout(model, work))
        avail, rmse = drive_numbers(model, drives, work / "runs")
        sets[name]["sim_drives_super_availability"] = avail
        sets[name]["sim_drives_super_path_rmse"] = rmse
        avail, rmse = drive_numbers(model, [DEMO], work / "runs")
        sets[name]["demo_super_availability"] = avail
        sets[name]["demo_super_path_rmse"] = rmse
        assert set(sets[name]) == set(SETS), sorted(set(sets[name]) ^ set(SETS))
        ms = time_model(model, "segmentation", threads=1)["median_ms"]
        releases[name] = {
            "sets": {
                k: round(float(v), 7 if k.endswith("_rmse") else 4) for k, v in sets[name].items()
            },
            "ms_per_frame_same_run": {"model": round(ms, 2), "reference": round(reference_ms, 2)},
            "command": (
                f"python pipelines/release_eval.py {shlex.join(models)} "
                f"({datetime.now(UTC):%Y-%m-%d}, {uptime}); real sets: real frames never "
                "trained on; sim_heldout, sim_drives and demo: simulated"
            ),
        }
        print(json.dumps({"model": name, **releases[name]}), flush=True)
    for name in releases:
        print(judge(name, releases).line(), flush=True)
    if args.json is not None:
        args.json.write_text(json.dumps(releases, indent=2) + "\n", encoding="utf-8")
    if args.update_cards:
        from superlane_tools.scene.model_card import card_path_for, load_card, write_card
        from superlane_tools.scene.onnx_backend import resolve_model

        for model in models:
            path = card_path_for(model) if model.endswith(".onnx") else resolve_model(model)[1]
            card = load_card(path)
            metrics = {**dict(card.metrics), RELEASE: releases[_name(model)]}
            write_card(replace(card, metrics=metrics), path)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
