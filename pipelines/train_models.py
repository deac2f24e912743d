"""Rebuild, evaluate and (optionally) ship the scene models: super_seg_v4 and ego_corridor_v3.

Steps, all seeded:

1. Simulate a training set (400 frames, seed 11) and a held-out set (40 frames, seed 99) with
   ``slt simulate dataset`` at 640x360 (reused when present).
2. Train both networks with ``slt train`` (run as subprocesses, at the same time, one torch
   thread each) on the heterogeneous recipe:

   * segmentation, two stages: TuSimple ``train_frames`` (all but the last 30 frames, weight
     0.45), CamVid ``train`` (weight 0.2, levels 1-2 only: its road includes the markings) and
     the simulator (weight 0.35); 3600 steps of 8 random 320x192 windows of 512x288 frames
     (scale, roll, pitch, flip, photometric, shadow, blur, JPEG, noise), cross-entropy per head
     + lane-marking Dice in 3 row bands; then 1000 steps from those weights (lr 0.0015, seed 1)
     with the TuSimple markings' vicinity labelled road (``expand_m: 0.6``, SUPER II-B), from a
     dataset list written into ``--work``. Without real data: the first stage on the simulator;
   * corridor: TuSimple ego lanes (weight 0.5) and the simulator (0.5), 900 steps of 8 full
     652x360 frames, BCE + Dice, unknown far-field rows masked.

3. Evaluate (no training data): simulator held-out metrics; real validation frames (the last 30
   of TuSimple ``train_frames`` and the 6 of ``tusimple/frames``): lane-marking support of the
   segmentation and corridor IoU against the labelled ego lane; CamVid ``val`` level-1 / level-2
   mIoU; KITTI ``um_000000`` ego-lane IoU; onnxruntime ms per frame on one thread. The numbers go
   into the model cards. The end-to-end LaneEval chain is ``pipelines/real_frames_eval.py``
   (``--update-cards`` writes its numbers into the cards).
4. ``--ship``: copy models and cards into ``superlane_tools/models/``.

``--recipe lite0`` trains the segmentation on the ImageNet-pretrained EfficientNet-Lite0 encoder
instead (``super_seg_v5``): one stage, TuSimple with the marking expansion (weight 0.45), CamVid
(0.2) and 160 simulator frames (0.35), camera-geometry augmentation (``--augment camera``),
random 320x192 windows, 8 per step, lr 0.002 (encoder 0.0005), a wall-clock budget of
``--budget-s`` seconds (4500 by default; the learning-rate schedule follows it) capped at 6000
steps, torch threads = the cores (run nothing CPU-heavy beside it). It checkpoints to
``checkpoints/NAME.ckpt.pt`` every 5 minutes and resumes from it when present (so a run cut
short continues with the same command, also on a fresh clone with the checkpoint committed),
and validates every 300 steps on the real dev sets (TuSimple dev, the held-out CULane day clip,
CULane night, CamVid val), exporting the weights best on the worst set. ``--no-camvid`` leaves
CamVid (CC BY-NC) out: a model for commercial use.

``--recipe canonical`` trains the next segmentation model (``super_seg_v6``; ``_nc`` without
CamVid), the recommended fast variant ``--arch lite0-s16`` at 512x160 in the canonical virtual
camera (``--canonical-camera --augment canonical``, no crop: it would move the horizon row the
canonical camera fixes): TuSimple ``train_frames`` less its 30 dev frames (weight 0.35, marking
expansion), the real CULane day clip of driver 23 (0.2; its camera estimated from its frames
without the labels, as ``pipelines/culane_night.py`` does, into ``WORK/culane_day_train.yaml``, so
it is resampled into the canonical camera; driver 161 is the held-out clip and never trained
on), CamVid (0.15, camera unknown: as it is) and the 160 simulator frames (0.3). Torch threads =
the cores, a budget of ``--budget-s`` seconds capped at ``--steps`` (6000), the checkpoint
``checkpoints/super_seg_v6.ckpt.pt`` always resumed (rerun the same command to continue),
validation every ``--validate-every`` steps on the real dev sets keeping the weights with the best
worst margin over the shipped default (``--validate-against super_seg_v4``: per set, the score
minus the default's; a release must not lose on any set, and the hardest set is not where it
loses).

``--recipe near`` trains ``super_seg_v7``: the canonical recipe's command (same data, validation
against the shipped default) at 512x224 with ``--canonical-near-m 3.4`` (the bottom row sees the
road 3.4 m ahead instead of 5 m: the near field, where lanes start, which the 512x160 band cut
off), ``--lr 0.001``, fine-tuned (``--init``) from the canonical checkpoint
``checkpoints/super_seg_v6.ckpt.pt`` (step 5118), checkpointing to
``checkpoints/super_seg_v7.ckpt.pt``. Trained with ``--budget-s 3000``.

``--recipe half`` trains ``super_seg_v8``: the near recipe's command with ``--arch
lite0-s16-half`` (the drivable and lane-marking heads refined at 1/2 of the input: at 1/4, a
distant dash a few pixels long vanishes, and the fitted lanes end short), fine-tuned from the
near checkpoint ``checkpoints/super_seg_v7.ckpt.pt`` (the new 1/2 stage starts as a zero
correction: the same outputs as v7 to start), checkpointing to ``checkpoints/super_seg_v8.ckpt.pt``.

``--quick`` runs the same steps on a few frames and steps (CI). ``--device cuda`` trains on a GPU.

Usage:
    python pipelines/train_models.py [--quick] [--work DIR] [--out DIR] [--ship]
        [--task segmentation|corridor|both] [--no-train] [--no-eval] [--device cpu|cuda]
        [--realdata DIR] [--json results.json] [--recipe v4|lite0|canonical|near|half]
        [--budget-s S] [--steps N] [--validate-every N] [--no-camvid]
"""

from __future__ import annotations

import argparse
import json
import os
import shlex
import shutil
import subprocess
import sys
import threading
import time
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parents[1]
SLT = str(Path(sys.executable).with_name("slt"))
TEST_SEED, TRAIN_SEED, MODEL_SEED = 99, 11, 0
SEG_NAME, COR_NAME = "super_seg_v4", "ego_corridor_v3"
TASKS = ("segmentation", "corridor")
LITE_NAME, LITE_NC_NAME = "super_seg_v5", "super_seg_v5_nc"
"""The lite0 recipe's model, and its variant without CamVid (no non-commercial data)."""
LITE_SIM_FRAMES, LITE_STEPS, LITE_BUDGET_S = 160, 6000, 4500.0
CANON_NAME, CANON_NC_NAME = "super_seg_v6", "super_seg_v6_nc"
"""The canonical recipe's model (lite0-s16, 512x160, canonical camera); _nc: without CamVid."""
CANON_ARCH, CANON_SIZE = "lite0-s16", "512x160"
NEAR_NAME, NEAR_SIZE, NEAR_M, NEAR_LR = "super_seg_v7", "512x224", 3.4, 0.001
"""The near-field recipe's model: the canonical one at 512x224, bottom row 3.4 m ahead."""
HALF_NAME, HALF_ARCH = "super_seg_v8", "lite0-s16-half"
"""The half recipe's model: the near one with its fine heads refined at 1/2 of the input."""
CULANE_TRAIN = "culane/driver_23_05151649_0422"
"""The CULane day clip trained on (pipelines/culane_night.py DAY_TRAIN_FOLDER)."""
CULANE_HELD_OUT = "culane/driver_161_06030819_0755"
"""The held-out CULane day clip: validation only, never in a training list."""
EXPAND_M = 0.6
"""Road band on each side of a TuSimple marking in the second segmentation stage, metres."""


@dataclass(frozen=True)
class Plan:
    """Sizes of one pipeline run."""

    sim_frames: int
    test_frames: int
    image_size: tuple[int, int]
    seg_steps: int
    seg_expand_steps: int
    cor_steps: int
    batch: int
    max_frames: int | None


FULL = Plan(400, 40, (640, 360), 3600, 1000, 900, 8, None)
QUICK = Plan(4, 2, (256, 144), 2, 2, 2, 2, 2)


def _size(size: tuple[int, int]) -> str:
    return f"{size[0]}x{size[1]}"


def make_dataset(folder: Path, frames: int, seed: int, size: tuple[int, int]) -> str:
    """Write a simulator dataset into ``folder`` (reused if indexed); return the command."""
    from superlane_tools.reporting.layout import DatasetLayout

    command = [
        "simulate", "dataset", "--out", str(folder), "--frames", str(frames), "--seed", str(seed),
        "--width", str(size[0]), "--height", str(size[1]), "--overwrite",
    ]  # fmt: skip
    if not DatasetLayout(folder).index.is_file():
        subprocess.run([SLT, *command], check=True, capture_output=True, text=True)
    return shlex.join(["slt", *command])


def expand_list(realdata: Path, sim: Path, work: Path) -> Path:
    """Write the second segmentation stage's dataset list (TuSimple with ``expand_m``)."""
    path = work / "datasets_expand.yaml"
    rows = [
        f"  - {{reader: tusimple, folder: {realdata / 'tusimple' / 'train_frames'}, "
        f"weight: 0.45, expand_m: {EXPAND_M}}}",
        f"  - {{reader: camvid, folder: {realdata / 'camvid'}, weight: 0.2}}",
        f"  - {{reader: sim, folder: {sim}, weight: 0.35}}",
    ]
    path.write_text("datasets:\n" + "\n".join(rows) + "\n", encoding="utf-8")
    return path


def train_commands(
    sim: Path, realdata: Path | None, out: Path, work: Path, plan: Plan, device: str
) -> dict[str, list[list[str]]]:
    """Return each model's ``slt train`` argument lists, run one after another."""
    seg_data = [f"sim:0.35={sim}"]
    cor_data = [f"sim:0.5={sim}"]
    if realdata is not None:
        tusimple = realdata / "tusimple" / "train_frames"
        seg_data = [f"tusimple:0.45={tusimple}", f"camvid:0.2={realdata / 'camvid'}", *seg_data]
        cor_data = [f"tusimple:0.5={tusimple}", *cor_data]
    common = ["--batch", str(plan.batch), "--threads", "1", "--device", device]
    if plan.max_frames is not None:
        common += ["--max-frames", str(plan.max_frames)]
    seg_model = out / f"{SEG_NAME}.onnx"
    stage1 = work / f"{SEG_NAME}_stage1.onnx" if realdata is not None else seg_model
    shape = ["--size", "512x288", "--crop", "320x192", "--dice-bands", "3"]
    seg = ["train", "segmentation", *(a for d in seg_data for a in ("--data", d))]
    seg += ["--out", str(stage1), "--steps", str(plan.seg_steps), "--lr", "0.003", *shape]
    seg += ["--seed", str(MODEL_SEED), *common]
    seg_stages = [seg]
    if realdata is not None:
        listing = expand_list(realdata, sim, work)
        init = stage1.with_name(stage1.name.removesuffix(".onnx") + ".ckpt.pt")
        expand = ["train", "segmentation", "--datasets", str(listing), "--out", str(seg_model)]
        expand += ["--steps", str(plan.seg_expand_steps), "--lr", "0.0015", *shape]
        expand += ["--seed", str(MODEL_SEED + 1), "--init", str(init), *common]
        seg_stages.append(expand)
    cor = ["train", "corridor", *(a for d in cor_data for a in ("--data", d))]
    cor += ["--out", str(out / f"{COR_NAME}.onnx"), "--steps", str(plan.cor_steps), "--lr", "0.002"]
    cor += ["--size", "652x360", "--seed", str(MODEL_SEED), *common]
    return {"segmentation": seg_stages, "corridor": [cor]}


def lite0_list(realdata: Path | None, sim: Path, work: Path, camvid: bool) -> Path:
    """Write the lite0 recipe's dataset list (TuSimple with ``expand_m``, CamVid, simulator)."""
    path = work / ("datasets_lite0.yaml" if camvid else "datasets_lite0_nc.yaml")
    rows = [f"  - {{reader: sim, folder: {sim.resolve()}, weight: 0.35}}"]
    if realdata is not None:
        tusimple = realdata.resolve() / "tusimple" / "train_frames"
        rows.insert(
            0, f"  - {{reader: tusimple, folder: {tusimple}, weight: 0.45, expand_m: {EXPAND_M}}}"
        )
        if camvid:
            rows.insert(
                1, f"  - {{reader: camvid, folder: {realdata.resolve() / 'camvid'}, weight: 0.2}}"
            )
    path.write_text("datasets:\n" + "\n".join(rows) + "\n", encoding="utf-8")
    return path


def culane_camera(realdata: Path, work: Path) -> Path:
    """Estimate the driver-23 clip's camera from its frames (labels unused); reuse it if present."""
    out = work / "culane_day_train.yaml"
    if not out.is_file():
        sys.path.insert(0, str(Path(__file__).resolve().parent))
        from culane_night import estimate_camera

        estimate_camera(realdata, out, CULANE_TRAIN)
    return out.resolve()


def canonical_list(
    realdata: Path | None, sim: Path, work: Path, camvid: bool, camera: Path | None
) -> Path:
    """Write the canonical recipe's dataset list (TuSimple, CULane driver 23, CamVid, simulator).

    ``camera``: the CULane clip's estimated camera (None: the clip is left out).
    """
    path = work / ("datasets_canonical.yaml" if camvid else "datasets_canonical_nc.yaml")
    rows = []
    if realdata is not None:
        root = realdata.resolve()
        rows.append(
            f"  - {{reader: tusimple, folder: {root / 'tusimple' / 'train_frames'}, "
            f"weight: 0.35, expand_m: {EXPAND_M}}}"
        )
        if camera is not None:
            rows.append(
                f"  - {{reader: culane, folder: {root / CULANE_TRAIN}, weight: 0.2, "
                f"expand_m: {EXPAND_M}, camera: {camera}}}"
            )
        if camvid:
            rows.append(f"  - {{reader: camvid, folder: {root / 'camvid'}, weight: 0.15}}")
    rows.append(f"  - {{reader: sim, folder: {sim.resolve()}, weight: 0.3}}")
    if any(CULANE_HELD_OUT in row for row in rows):
        raise RuntimeError(f"{CULANE_HELD_OUT} is the held-out clip: never train on it")
    path.write_text("datasets:\n" + "\n".join(rows) + "\n", encoding="utf-8")
    return path


def canonical_command(
    listing: Path,
    out: Path,
    plan: Plan,
    device: str,
    budget_s: float,
    steps: int,
    checkpoint: Path,
    val: tuple[Path | None, int],
    threads: int | None = None,
) -> list[str]:
    """Return the canonical recipe's ``slt train`` arguments (torch threads: every core).

    ``threads``: torch threads (None: every core; 1 on a machine shared with other jobs, where
    threads waiting for each other at every operation cost more than the second core gives).

    ``val``: ``(real-data folder, every N steps)``; no validation without real data or with 0.
    """
    args = ["train", "segmentation", "--arch", CANON_ARCH, "--size", CANON_SIZE]
    args += ["--canonical-camera", "--augment", "canonical"]
    args += ["--datasets", str(listing), "--out", str(out), "--steps", str(steps)]
    args += ["--budget-s", f"{budget_s:g}", "--lr", "0.002", "--dice-bands", "3"]
    args += ["--seed", str(MODEL_SEED), "--batch", str(plan.batch), "--device", device]
    args += ["--threads", str(threads or os.cpu_count() or 1)]
    if plan.max_frames is not None:
        args += ["--max-frames", str(plan.max_frames)]
    args += ["--checkpoint", str(checkpoint), "--resume", "--checkpoint-every-s", "300"]
    realdata, every = val
    if realdata is not None and every > 0:
        from superlane_tools.scene.onnx_backend import DEFAULT_SEGMENTATION_MODEL

        args += ["--val-data", str(realdata.resolve()), "--validate-every", str(every)]
        args += ["--validate-against", DEFAULT_SEGMENTATION_MODEL]  # the model to beat
    return args


def near_command(canonical: list[str], out: Path, checkpoint: Path, init: Path) -> list[str]:
    """Return the near-field recipe's ``slt train`` arguments (``super_seg_v7``).

    The canonical recipe's command (same data, validation against the default) at
    :data:`NEAR_SIZE` with the canonical bottom row :data:`NEAR_M` ahead, fine-tuned from the
    canonical model's checkpoint ``init`` at :data:`NEAR_LR`.
    """
    values = {"--size": NEAR_SIZE, "--lr": f"{NEAR_LR:g}", "--out": str(out)}
    values["--checkpoint"] = str(checkpoint)
    args = list(canonical)
    for flag, value in values.items():
        args[args.index(flag) + 1] = value
    return [*args, "--canonical-near-m", f"{NEAR_M:g}", "--init", str(init)]


def half_command(near: list[str], out: Path, checkpoint: Path, init: Path) -> list[str]:
    """Return the half recipe's ``slt train`` arguments (``super_seg_v8``).

    The near recipe's command with :data:`HALF_ARCH`, fine-tuned from the near model's
    checkpoint ``init`` (its weights fit every module but the new 1/2 stage).
    """
    values = {"--arch": HALF_ARCH, "--out": str(out), "--checkpoint": str(checkpoint)}
    values["--init"] = str(init)
    args = list(near)
    for flag, value in values.items():
        args[args.index(flag) + 1] = value
    return args


def lite0_command(
    listing: Path,
    out: Path,
    plan: Plan,
    device: str,
    budget_s: float,
    steps: int,
    resume: tuple[Path, Path | None] | None = None,
) -> list[str]:
    """Return the lite0 recipe's ``slt train`` arguments (torch threads: every core).

    ``resume``: ``(checkpoint, real-data folder)``: resume from / checkpoint to that file (every
    5 minutes; ``checkpoints/NAME.ckpt.pt`` commits and resumes on a fresh clone) and validate
    every 300 steps on the real dev sets (exporting the weights best on the worst set).
    """
    args = ["train", "segmentation", "--arch", "lite0", "--augment", "camera"]
    args += ["--datasets", str(listing), "--out", str(out), "--steps", str(steps)]
    args += ["--budget-s", f"{budget_s:g}", "--lr", "0.002", "--size", "512x288"]
    args += ["--crop", "320x192", "--dice-bands", "3", "--seed", str(MODEL_SEED)]
    args += ["--batch", str(plan.batch), "--device", device]
    if plan.max_frames is not None:
        args += ["--max-frames", str(plan.max_frames)]
    if resume is not None:
        checkpoint, realdata = resume
        args += ["--checkpoint", str(checkpoint), "--resume", "--checkpoint-every-s", "300"]
        if realdata is not None:
            args += ["--val-data", str(realdata), "--validate-every", "300"]
    return args


def _run_stages(task: str, stages: list[list[str]], work: Path, env: dict[str, str]) -> int:
    """Run one model's training commands in order into ``work/train_<task>.log``."""
    with (work / f"train_{task}.log").open("w", encoding="utf-8") as log:
        for args in stages:
            proc = subprocess.run([SLT, *args], stdout=log, stderr=log, env=env, check=False)
            if proc.returncode != 0:
                return proc.returncode
    return 0


def run_training(commands: dict[str, list[list[str]]], work: Path) -> dict[str, Any]:
    """Train the models at once (one process chain each); return wall times."""
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    start = time.perf_counter()
    timings: dict[str, Any] = {}

    def run(task: str) -> None:
        code = _run_stages(task, commands[task], work, env)
        timings[task] = {"wall_seconds": round(time.perf_counter() - start, 1), "exit": code}

    threads = [threading.Thread(target=run, args=(task,)) for task in commands]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    for task, timing in timings.items():
        if timing["exit"] != 0:
            tail = (work / f"train_{task}.log").read_text(encoding="utf-8")[-2000:]
            raise RuntimeError(f"slt train {task} failed ({timing['exit']}):\n{tail}")
    return timings


def evaluate(
    seg: Path, cor: Path, test: Path, realdata: Path | None, tasks: tuple[str, ...] = TASKS
) -> dict[str, Any]:
    """Evaluate the models of ``tasks``; write metrics and timings into their cards; return them."""
    from superlane_tools.scene.onnx_backend import OnnxSegmentationBackend
    from superlane_tools.training.evaluate import (
        backend_marking_hit_rate,
        camvid_scores,
        evaluate_corridor_on_dataset,
        evaluate_segmentation_on_dataset,
        kitti_ego_lane_iou,
        time_model,
        tusimple_corridor_scores,
        update_card,
    )

    seg_metrics: dict[str, Any] = {}
    cor_metrics: dict[str, Any] = {}
    tus = None if realdata is None else realdata / "tusimple"
    if "segmentation" in tasks:
        seg_metrics["sim_heldout"] = evaluate_segmentation_on_dataset(seg, test)
        if realdata is not None and tus is not None:
            from superlane_tools.camera import load_camera
            from superlane_tools.scene.backends import backend_from_name

            # TuSimple's camera is known: a model trained in the canonical camera runs in it
            # there (as slt segment --camera tusimple runs it); CamVid's is not: as it is.
            in_camera = backend_from_name("onnx", model=str(seg), camera=load_camera("tusimple"))
            seg_metrics["tusimple_frames"] = backend_marking_hit_rate(in_camera, tus / "frames")
            backend = OnnxSegmentationBackend(seg)
            seg_metrics["camvid_val"] = camvid_scores(backend, realdata / "camvid", "val")
    if "corridor" in tasks:
        cor_metrics["sim_heldout"] = evaluate_corridor_on_dataset(cor, test)
        if realdata is not None and tus is not None:
            cor_metrics["tusimple_val_ego_lane"] = tusimple_corridor_scores(
                cor, [(tus / "train_frames", "val"), (tus / "frames", "val")]
            )
            cor_metrics["kitti_road_um_000000"] = kitti_ego_lane_iou(cor, realdata / "kitti_road")
    results = {}
    if "segmentation" in tasks:
        timing = time_model(seg, "segmentation", threads=1)
        results["segmentation"] = update_card(seg, seg_metrics, timing)
    if "corridor" in tasks:
        results["corridor"] = update_card(cor, cor_metrics, time_model(cor, "corridor", threads=1))
    return {k: {"metrics": v.metrics, "ms_per_frame": v.ms_per_frame} for k, v in results.items()}


def record_pipeline(model: Path, timing: dict[str, Any], first_stage: Path | None = None) -> None:
    """Add the pipeline command, its wall time and any first training stage to a model's card."""
    from superlane_tools.scene.model_card import card_path_for, load_card, write_card

    card_path = card_path_for(model)
    card = load_card(card_path)
    argv = " ".join(sys.argv[1:]) if Path(sys.argv[0]).name == "train_models.py" else ""
    training = {
        **dict(card.training),
        "pipeline_command": f"python pipelines/train_models.py {argv}".strip(),
        "pipeline_wall_seconds": timing.get("wall_seconds"),
    }
    if first_stage is not None and card_path_for(first_stage).is_file():
        first = load_card(card_path_for(first_stage)).training
        training["first_stage"] = {
            key: first.get(key) for key in ("training_command", "steps", "train_seconds")
        }
    write_card(replace(card, training=training), card_path)


def main(argv: list[str] | None = None) -> int:
    """Run the pipeline; return the exit status."""
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="a few frames and steps (CI)")
    ap.add_argument("--work", type=Path, default=Path("runs/train_models"), help="datasets, logs")
    ap.add_argument("--out", type=Path, default=Path("runs/train_models/models"), help="models")
    ap.add_argument("--ship", action="store_true", help="copy models into superlane_tools/models")
    ap.add_argument("--task", choices=("segmentation", "corridor", "both"), default="both")
    ap.add_argument("--no-train", action="store_true", help="evaluate the models in --out only")
    ap.add_argument("--no-eval", action="store_true", help="train only, skip evaluation")
    ap.add_argument("--device", default="cpu", help="torch device for training (cpu, cuda)")
    ap.add_argument(
        "--realdata",
        type=Path,
        default=Path(os.environ.get("SLT_REALDATA", REPO.parent / "shared" / "data")),
        help="real data folder (TuSimple, CamVid, KITTI); simulator only when absent",
    )
    ap.add_argument("--json", type=Path, help="write the results here too")
    ap.add_argument(
        "--recipe",
        choices=("v4", "lite0", "canonical", "near", "half"),
        default="v4",
        help="segmentation recipe",
    )
    ap.add_argument(
        "--budget-s", type=float, default=LITE_BUDGET_S, help="lite0/canonical time budget, s"
    )
    ap.add_argument("--steps", type=int, default=LITE_STEPS, help="lite0/canonical step cap")
    ap.add_argument(
        "--threads", type=int, default=None, help="canonical: torch threads (default: the cores)"
    )
    ap.add_argument(
        "--validate-every", type=int, default=300, help="canonical: validate every N steps"
    )
    ap.add_argument("--no-camvid", action="store_true", help="without CamVid (CC BY-NC)")
    args = ap.parse_args(argv)

    from superlane_tools.training import TrainingError, require_torch

    try:
        require_torch()
    except TrainingError as err:
        print(f"train_models: {err}", file=sys.stderr)
        return 1
    plan = QUICK if args.quick else FULL
    size = _size(plan.image_size)
    sim_frames = plan.sim_frames
    if args.recipe in ("lite0", "canonical") and not args.quick:
        sim_frames = LITE_SIM_FRAMES
    sim = args.work / f"sim_train_s{TRAIN_SEED}_{sim_frames}_{size}"
    test = args.work / f"sim_test_s{TEST_SEED}_{plan.test_frames}_{size}"
    args.work.mkdir(parents=True, exist_ok=True)
    args.out.mkdir(parents=True, exist_ok=True)
    results: dict[str, Any] = {
        "commands": {
            "train_dataset_0": make_dataset(sim, sim_frames, TRAIN_SEED, plan.image_size),
            "test_dataset": make_dataset(test, plan.test_frames, TEST_SEED, plan.image_size),
        }
    }
    realdata = args.realdata if (args.realdata / "tusimple" / "train_frames").is_dir() else None
    commands = train_commands(sim, realdata, args.out, args.work, plan, args.device)
    seg = args.out / f"{SEG_NAME}.onnx"
    if args.recipe == "lite0":
        seg = args.out / f"{LITE_NC_NAME if args.no_camvid else LITE_NAME}.onnx"
        listing = lite0_list(realdata, sim, args.work, camvid=not args.no_camvid)
        steps = plan.seg_steps if args.quick else args.steps
        budget = 60.0 if args.quick else args.budget_s
        ckpt_dir = args.work if args.quick else REPO / "checkpoints"
        resume = (ckpt_dir / f"{seg.stem}.ckpt.pt", realdata)
        commands["segmentation"] = [
            lite0_command(listing, seg, plan, args.device, budget, steps, resume)
        ]
    if args.recipe in ("canonical", "near", "half"):
        seg = args.out / f"{CANON_NC_NAME if args.no_camvid else CANON_NAME}.onnx"
        camera = culane_camera(realdata, args.work) if realdata is not None else None
        listing = canonical_list(realdata, sim, args.work, not args.no_camvid, camera)
        ckpt = (args.work if args.quick else REPO / "checkpoints") / f"{seg.stem}.ckpt.pt"
        commands["segmentation"] = [
            canonical_command(
                listing, seg, plan, args.device, 60.0 if args.quick else args.budget_s,
                plan.seg_steps if args.quick else args.steps, ckpt,
                (realdata, args.validate_every), args.threads,
            )
        ]  # fmt: skip
    if args.recipe in ("near", "half"):  # fine-tuned from the canonical recipe's checkpoint
        init, seg = ckpt, args.out / f"{NEAR_NAME}{'_nc' if args.no_camvid else ''}.onnx"
        ckpt = ckpt.with_name(f"{seg.stem}.ckpt.pt")
        commands["segmentation"] = [near_command(commands["segmentation"][0], seg, ckpt, init)]
    if args.recipe == "half":  # fine-tuned from the near recipe's checkpoint
        init, seg = ckpt, args.out / f"{HALF_NAME}{'_nc' if args.no_camvid else ''}.onnx"
        ckpt = ckpt.with_name(f"{seg.stem}.ckpt.pt")
        commands["segmentation"] = [half_command(commands["segmentation"][0], seg, ckpt, init)]
    commands = {t: c for t, c in commands.items() if args.task in (t, "both")}
    results["commands"].update(
        {t: " && ".join(shlex.join(["slt", *c]) for c in stages) for t, stages in commands.items()}
    )
    cor = args.out / f"{COR_NAME}.onnx"
    if not args.no_train:
        print("training: " + " ; ".join(results["commands"][t] for t in commands), flush=True)
        timings = run_training(commands, args.work)
        for task, timing in timings.items():
            if task == "segmentation":
                first = args.work / f"{SEG_NAME}_stage1.onnx" if args.recipe == "v4" else None
                record_pipeline(seg, timing, first)
            else:
                record_pipeline(cor, timing)
        results["training"] = timings
    if not args.no_eval:
        tasks = tuple(t for t in TASKS if args.task in (t, "both"))
        results.update(evaluate(seg, cor, test, realdata, tasks))
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
