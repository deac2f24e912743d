"""Train, evaluate and (optionally) ship the scene models: segmentation and ego corridor.

Steps, all seeded:

1. Simulate training sets and a held-out set (``slt simulate dataset``; different seeds, so
   different worlds). ``--toy`` uses the procedural toy dataset instead (no simulator needed).
2. Train both networks on CPU (``slt train segmentation|corridor``), export ONNX + model cards.
   v2 recipe: 600 frames (seeds 11, 21, 22), segmentation on 320x176 crops with a lane-marking
   Dice term, corridor on full frames (position channel, input pooled by 2) with BCE + Dice,
   one-cycle LR, one torch thread per network (``--task`` trains one, so both can run at once).
3. Evaluate: held-out simulator metrics (mIoU per level, lane-marking IoU, corridor IoU), real
   frames (TuSimple: labelled lane points on predicted markings; KITTI: ego-lane IoU), and the
   onnxruntime milliseconds per frame; the numbers go into the model cards.
4. ``--ship``: copy models and cards into ``superlane_tools/models/``.

The exact commands run are recorded in each card (the library is called directly, with the
equivalent ``slt`` command line recorded, so the pipeline also runs before ``slt train`` is
wired into the CLI).

Usage:
    python pipelines/train_models.py [--quick] [--toy] [--work DIR] [--out DIR] [--ship]
        [--task segmentation|corridor|both] [--no-train] [--seg-epochs N] [--corridor-epochs N]
        [--threads N] [--realdata DIR] [--json results.json]
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import sys
import time
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parents[1]
TEST_SEED, MODEL_SEED = 99, 0
SEG_NAME, COR_NAME = "super_seg_v2", "ego_corridor_v2"


@dataclass(frozen=True)
class Plan:
    """Sizes of one pipeline run.

    ``train_sets`` is one ``(frames, seed)`` per simulated training set (concatenated).
    """

    train_sets: tuple[tuple[int, int], ...]
    test_frames: int
    image_size: tuple[int, int]
    seg_size: tuple[int, int]
    seg_crop: tuple[int, int] | None
    cor_size: tuple[int, int]
    cor_crop: tuple[int, int] | None
    seg_epochs: int
    cor_epochs: int
    batch: int
    lr: float


FULL = Plan(
    ((300, 11), (150, 21), (150, 22)),
    40,
    (640, 360),
    (512, 288),
    (320, 176),
    (652, 360),
    None,
    10,
    12,
    8,
    2e-3,
)
QUICK = Plan(((4, 11),), 2, (256, 144), (128, 72), None, (163, 90), None, 1, 1, 2, 2e-3)


def _size(size: tuple[int, int]) -> str:
    return f"{size[0]}x{size[1]}"


def make_dataset(folder: Path, frames: int, seed: int, size: tuple[int, int], toy: bool) -> str:
    """Write a dataset into ``folder`` (reused if its index exists); return the command."""
    if toy:
        from superlane_tools.training.toy_dataset import write_toy_dataset

        command = f"write_toy_dataset({str(folder)!r}, frames={frames}, seed={seed})"
        if not (folder / "index.parquet").is_file():
            write_toy_dataset(folder, frames, size[0], size[1], seed)
        return command
    from superlane_tools.simulation.dataset import simulate_dataset

    command = (
        f"slt simulate dataset --out {folder} --frames {frames} --seed {seed} "
        f"--width {size[0]} --height {size[1]}"
    )
    if not (folder / "index.parquet").is_file():
        simulate_dataset(folder, frames, None, seed, size[0], size[1], command=command)
    return command


def train_one(
    task: str, data: list[Path], out: Path, plan: Plan, threads: int
) -> tuple[float, dict[str, Any]]:
    """Train one model on the concatenated ``data`` folders; return (seconds, summary)."""
    from superlane_tools.training.train import TrainParams, train

    seg = task == "segmentation"
    size, crop = (plan.seg_size, plan.seg_crop) if seg else (plan.cor_size, plan.cor_crop)
    epochs = plan.seg_epochs if seg else plan.cor_epochs
    command = (
        f"slt train {task} {' '.join(f'--data {d}' for d in data)} --out {out} "
        f"--epochs {epochs} --batch {plan.batch} --lr {plan.lr} --size {_size(size)} "
        f"--seed {MODEL_SEED} --threads {threads}" + (f" --crop {_size(crop)}" if crop else "")
    )
    params = TrainParams(
        task,
        data[0],
        out,
        extra_data=tuple(data[1:]),
        epochs=epochs,
        batch=plan.batch,
        lr=plan.lr,
        size=size,
        crop=crop,
        seed=MODEL_SEED,
        threads=threads,
        name=out.name.removesuffix(".onnx"),
        command=command,
    )
    start = time.perf_counter()
    last = [0.0]

    def progress(step: int, total: int, loss: float) -> None:
        if time.perf_counter() - last[0] > 30 or step == total:
            last[0] = time.perf_counter()
            print(f"  {task}: step {step}/{total} loss {loss:.4f}", flush=True)

    result = train(params, progress)
    _record_pipeline(result.card_path, task)
    return time.perf_counter() - start, {"epoch_losses": [round(v, 4) for v in result.epoch_losses]}


def _record_pipeline(card_path: Path, task: str) -> None:
    """Add the pipeline command that really ran to the card (``slt train`` takes one folder)."""
    from superlane_tools.scene.model_card import load_card, write_card

    card = load_card(card_path)
    argv = " ".join(sys.argv[1:]) if Path(sys.argv[0]).name == "train_models.py" else ""
    pipeline = f"python pipelines/train_models.py {argv}".strip()
    training = {**dict(card.training), "pipeline_command": pipeline, "pipeline_task": task}
    write_card(replace(card, training=training), card_path)


def evaluate(
    seg: Path, cor: Path, test: Path, realdata: Path | None, threads: int
) -> dict[str, Any]:
    """Evaluate both models; write metrics and timings into their cards; return them."""
    from superlane_tools.training.evaluate import (
        evaluate_corridor_on_dataset,
        evaluate_segmentation_on_dataset,
        kitti_ego_lane_iou,
        time_model,
        tusimple_marking_hit_rate,
        update_card,
    )

    results: dict[str, Any] = {}
    seg_metrics: dict[str, Any] = {"sim_heldout": evaluate_segmentation_on_dataset(seg, test)}
    cor_metrics: dict[str, Any] = {"sim_heldout": evaluate_corridor_on_dataset(cor, test)}
    if realdata is not None and (realdata / "tusimple" / "frames" / "labels.json").is_file():
        seg_metrics["tusimple_frames"] = tusimple_marking_hit_rate(
            seg, realdata / "tusimple" / "frames"
        )
    if realdata is not None and (realdata / "kitti_road").is_dir():
        cor_metrics["kitti_road_um_000000"] = kitti_ego_lane_iou(cor, realdata / "kitti_road")
    results["segmentation"] = update_card(
        seg, seg_metrics, time_model(seg, "segmentation", threads=threads)
    )
    results["corridor"] = update_card(
        cor, cor_metrics, time_model(cor, "corridor", threads=threads)
    )
    return {k: {"metrics": v.metrics, "ms_per_frame": v.ms_per_frame} for k, v in results.items()}


def main(argv: list[str] | None = None) -> int:
    """Run the pipeline; return the exit status."""
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="tiny datasets, 1 epoch (CI)")
    ap.add_argument("--toy", action="store_true", help="toy dataset instead of the simulator")
    ap.add_argument("--work", type=Path, default=Path("runs/train_models"), help="datasets")
    ap.add_argument("--out", type=Path, default=Path("runs/train_models/models"), help="models")
    ap.add_argument("--ship", action="store_true", help="copy models into superlane_tools/models")
    ap.add_argument(
        "--task",
        choices=("segmentation", "corridor", "both"),
        default="both",
        help="train only one network (run two processes to train both at once)",
    )
    ap.add_argument("--no-train", action="store_true", help="evaluate the models in --out only")
    ap.add_argument("--no-eval", action="store_true", help="train only, skip evaluation")
    ap.add_argument("--test-frames", type=int, help="override the held-out set size")
    ap.add_argument("--seg-epochs", type=int, help="override segmentation epochs")
    ap.add_argument("--corridor-epochs", type=int, help="override corridor epochs")
    ap.add_argument("--threads", type=int, default=1, help="torch / onnxruntime threads")
    ap.add_argument(
        "--realdata",
        type=Path,
        default=Path(os.environ.get("SLT_REALDATA", REPO.parent / "shared" / "data")),
        help="real data folder (TuSimple frames, KITTI road); skipped when absent",
    )
    ap.add_argument("--json", type=Path, help="write the results here too")
    args = ap.parse_args(argv)

    from superlane_tools.training import TrainingError, require_torch

    try:
        require_torch()
    except TrainingError as err:
        print(f"train_models: {err}", file=sys.stderr)
        return 1
    plan = QUICK if args.quick else FULL
    plan = replace(
        plan,
        test_frames=args.test_frames or plan.test_frames,
        seg_epochs=args.seg_epochs or plan.seg_epochs,
        cor_epochs=args.corridor_epochs or plan.cor_epochs,
    )
    kind = "toy" if args.toy else "sim"
    size = _size(plan.image_size)
    train_dirs = [args.work / f"{kind}_train_s{seed}_{n}_{size}" for n, seed in plan.train_sets]
    test_dir = args.work / f"{kind}_test_s{TEST_SEED}_{plan.test_frames}_{size}"
    print(f"datasets: {', '.join(map(str, train_dirs))}; held out {test_dir}", flush=True)
    commands = {
        f"train_dataset_{i}": make_dataset(folder, n, seed, plan.image_size, args.toy)
        for i, (folder, (n, seed)) in enumerate(zip(train_dirs, plan.train_sets, strict=True))
    }
    commands["test_dataset"] = make_dataset(
        test_dir, plan.test_frames, TEST_SEED, plan.image_size, args.toy
    )
    args.out.mkdir(parents=True, exist_ok=True)
    seg, cor = args.out / f"{SEG_NAME}.onnx", args.out / f"{COR_NAME}.onnx"
    results: dict[str, Any] = {"commands": commands}
    if not args.no_train:
        timings = {}
        for task, path in (("segmentation", seg), ("corridor", cor)):
            if args.task in (task, "both"):
                seconds, summary = train_one(task, train_dirs, path, plan, args.threads)
                timings[task] = {"train_seconds": round(seconds, 1), **summary}
                print(f"trained {task} in {seconds:.0f} s -> {path}", flush=True)
        results["training"] = timings
    if not args.no_eval:
        realdata = args.realdata if (args.realdata / "README.md").is_file() else None
        results.update(evaluate(seg, cor, test_dir, realdata, args.threads))
    print(json.dumps(results, indent=2, default=str))
    if args.json:
        args.json.write_text(json.dumps(results, indent=2, default=str), encoding="utf-8")
    if args.ship:
        target = REPO / "superlane_tools" / "models"
        for path in (seg, cor):
            card = path.with_name(path.name.removesuffix(".onnx") + ".card.yaml")
            shutil.copy(path, target / path.name)
            shutil.copy(card, target / card.name)
        print(f"shipped {seg.name}, {cor.name} into {target}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
